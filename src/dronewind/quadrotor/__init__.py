"""The quadrotor system (SWUF-3D): wind from the attitude of hovering quadrotors.

Modules, in the order the data flow through them:

* :mod:`~dronewind.quadrotor.io`: readers of the UAV logs (CSV or PX4 ULog) and the tower reference;
* :mod:`~dronewind.quadrotor.drag`: the drag balance (seed 001 Eqs 9-18, seed 002 Eq. 1), attitude geometry;
* :mod:`~dronewind.quadrotor.wind`: wind from the attitude (the inversion), calibrated wind series of a UAV;
* :mod:`~dronewind.quadrotor.hover`: hover selection and position accuracy (seed 001 Sect. 4.3);
* :mod:`~dronewind.quadrotor.windows`: averaging windows paired with the tower, the calibration data set;
* :mod:`~dronewind.quadrotor.calibration`: the calibrators (individual, universal, pitch and yaw offsets,
  speed ranges; seed 001 Sect. 5, seed 002 Sect. 3.1);
* :mod:`~dronewind.quadrotor.validation`: validation tables (seed 001 Tables 2, 3, C1, C2, scenarios a-d)
  and the contract table;
* :mod:`~dronewind.quadrotor.chain`: the chain, Dataset in, Dataset out (L1, windows, tables, L2).
"""
