"""The quadrotor system (SWUF-3D): wind from the attitude of hovering quadrotors.

Readers of the UAV logs (CSV or PX4 ULog) and the tower reference
(:mod:`~dronewind.quadrotor.io`), the drag law, hover selection and the calibrations of
seed 001 and seed 002 (:mod:`~dronewind.quadrotor.calibration`).
"""
