"""The quadrotor system (SWUF-3D): wind from the attitude of hovering quadrotors.

Modules, in the order the data flow through them:

* :mod:`~dronewind.quadrotor.io`: readers of the UAV logs (CSV, and every format through ``read_quadrotor``),
  :mod:`~dronewind.quadrotor.ulog` (PX4 ULog) and :mod:`~dronewind.quadrotor.reference` (the tower reference);
* :mod:`~dronewind.quadrotor.drag`: the drag balance (Wetz et al. 2021, Eqs 9-18, Kistner et al. 2024, Eq. 1),
  attitude geometry;
* :mod:`~dronewind.quadrotor.wind`: wind from the attitude (the inversion), calibrated wind series of a UAV;
* :mod:`~dronewind.quadrotor.hover`: hover selection and position accuracy (Wetz et al. (2021), Sect. 4.3);
* :mod:`~dronewind.quadrotor.windows`: averaging windows paired with the tower, the calibration data set;
* :mod:`~dronewind.quadrotor.calibration`: the calibrators (individual, universal, pitch and yaw offsets,
  speed ranges; Wetz et al. (2021), Sect. 5, Kistner et al. (2024), Sect. 3.1);
* :mod:`~dronewind.quadrotor.validation`: validation tables (Wetz et al. (2021), Tables 2, 3, C1, C2, scenarios a-d)
  and the contract table;
* :mod:`~dronewind.quadrotor.chain`: the chain, Dataset in, Dataset out (L1, windows, tables, L2).
"""

__all__ = ["QUAD_TABLES"]

#: Campaign tables of :func:`dronewind.quadrotor.chain.compute_quadrotor_tables` (file stem ->
#: content); here, apart from the chain and its libraries, for the Snakefile that lists them as
#: outputs.
QUAD_TABLES: dict[str, str] = {
    "quadrotor_calibration": "contract table: one row per UAV (uav, pitch_offset_deg, yaw_offset_deg, rmse_ms, "
                             "bias_ms, ...)",
    "quadrotor_table2": "Wetz et al. (2021), Table 2: individual vs universal calibration, 10-min windows",
    "quadrotor_table3": "Wetz et al. (2021), Table 3: calibration scenarios a-d, 10-min windows",
    "quadrotor_tableC1": "Wetz et al. (2021), Table C1: as Table 2 with 2-min windows",
    "quadrotor_tableC2": "Wetz et al. (2021), Table C2: as Table 3 with 2-min windows",
    "quadrotor_direction": "speed and direction accuracy with scenario-d pitch and yaw offsets (Sect. 5.4)",
    "quadrotor_windows": "per 10-min window: reference, UAV speed per calibration, direction, tilt, variance",
    "quadrotor_profiles": "per flight and height: mean UAV and tower speed (Fig. 8)",
    "quadrotor_problems": "UAV logs left out and why",
}
