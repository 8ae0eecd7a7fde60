"""The virtual campaign: writes L0 files that the processing chain cannot tell from logged ones.

Modules: :mod:`~dronewind.simulate.atmosphere` (turbulent wind and temperature at points,
from the similarity functions of :mod:`dronewind.core.surface_layer`, the spectral model of
:mod:`~dronewind.simulate.spectral_model` and the mast constraint of
:mod:`~dronewind.simulate.constraint`; departures from the model in
:mod:`~dronewind.simulate.departures`), :mod:`~dronewind.simulate.payload` (SAMURAI-S flight:
INS, sonic and the mast sonics, with the flight plan in
:mod:`~dronewind.simulate.payload_flight`, the wind at the payload in
:mod:`~dronewind.simulate.payload_wind` and the pendulum and attitude in
:mod:`~dronewind.simulate.payload_motion`), :mod:`~dronewind.simulate.mast` (CSAT3
measurement model), :mod:`~dronewind.simulate.writers` (L0 formats),
:mod:`~dronewind.simulate.settings` (validation of the ``simulation:`` section, defaults
and ranges in :mod:`~dronewind.simulate.defaults`), :mod:`~dronewind.simulate.quadrotor` and
:mod:`~dronewind.simulate.tunnel` (SWUF-3D fleet and wind tunnel), with their own forward
drag physics in :mod:`~dronewind.simulate.airframe` (independent of the chain's inversion),
:mod:`~dronewind.simulate.rigid` (a sonic on a rigid mount of a hovering multicopter, with the
``platform_velocity_response`` mechanism)
and shared noise and lag processes in :mod:`~dronewind.simulate.common`. The simulator
imports no processing chain: its campaigns reach the chain only as files.

The ``simulation:`` section of a campaign manifest (payload flights and masts)
==============================================================================

Units are in the key names; every key except ``payload_flights.<id>.mean_speed_ms``,
``wind_from_deg`` and one of ``z_over_L`` / ``obukhov_length_m`` is optional. Defaults
and [ranges] below are those of ``defaults.PAYLOAD_DEFAULTS``, ``DEFECT_DEFAULTS``,
``MAST_DEFAULTS``, ``ATMOSPHERE_DEFAULTS`` and ``TURBULENCE_DEFAULTS`` (the authoritative tables); rates must be
whole numbers of Hz::

    simulation:
      seed: 2023                      # int >= 0; flight seed = sha256("<seed>:<flight id>")
      atmosphere:                     # defaults for every flight (overridable per flight)
        roughness_length_m: 0.1       # (0, 3]
        boundary_layer_height_m: 1000 # [50, 5000], only used when L < 0
        theta_mean_k: 288.15          # [220, 330], sonic temperature at z_ref_m
        # turbulence model, campaign-wide (drone and masts alike; not per flight):
        spectrum: kaimal              # kaimal | von_karman: u, v, w spectral shape (same
                                      #   sigmas and dissipation rate; atmosphere.reshape_field)
        sigma_u_factor: 1             # [0.5, 2] on the similarity sigma_u (also v, w:
        sigma_v_factor: 1             #   another isotropy; the inertial level moves by
        sigma_w_factor: 1             #   factor^2, the u-w coherency is kept)
        length_scale_factor: 1        # [0.5, 2] on the u, v, w spectral length scales:
                                      #   peak at f / factor, same variance
        speed_trend_ms_per_h: 0       # [-10, 10] m s-1 h-1, mean speed at z_ref_m changing
                                      #   linearly, 0 at the hover-window centre
        direction_trend_deg_per_h: 0  # [-120, 120] degree h-1, veering (+) or backing (-)
      payload:
        pendulum_length_m: 18                 # (0, 100] m
        mass_kg: 4                            # (0, 25] kg
        drag_area_m2: 0.06                    # (0, 2] m2
        min_damping_ratio: 0.03               # [0, 1] 1
        drone_mass_kg: 20                     # [1, 25] kg
        drone_drag_area_m2: 0.5               # [0, 5] m2
        drone_roll_jitter_deg: 0.5            # [0, 10] degree
        pitch_trim_deg: 1                     # [-15, 15] degree
        pitch_jitter_deg: 1                   # [0, 10] degree
        rope_pitch_fraction: 0                # [0, 1] share of the line's angle in the pitch
        rope_roll_fraction: 0                 # [0, 1] share of the line's angle in the roll
        yaw_time_constant_s: 15               # [0.1, 600] s
        yaw_jitter_deg: 3                     # [0, 30] degree
        attitude_jitter_time_s: 0.5           # [0.05, 60] s
        hover_jitter_m: 0.3                   # [0, 5] m
        hover_jitter_time_s: 3                # [0.1, 60] s
        sonic_rate_hz: 32                     # [4, 32] Hz
        ins_rate_hz: 50                       # [1, 200] Hz
        sonic_noise_ms: 0.02                  # [0, 1] m s-1
        sonic_resolution_ms: 0.01             # [0, 0.1] m s-1
        temperature_noise_k: 0.01             # [0, 1] K
        temperature_resolution_k: 0.01        # [0, 0.1] K
        temperature_offset_k: 0               # [-5, 5] K
        ins_velocity_noise_ms: 0.03           # [0, 1] m s-1
        ins_roll_pitch_noise_deg: 0.05        # [0, 2] degree
        ins_heading_noise_deg: 0.4            # [0, 5] degree
        ins_horizontal_position_noise_m: 0.01 # [0, 5] m
        ins_vertical_position_noise_m: 0.02   # [0, 5] m
        ins_noise_time_s: 1                   # [0, 100] s
        ins_heading_offset_deg: 0             # [0, 5] degree: heading error held over the flight
        ascent_rate_ms: 1.5                   # [0.1, 10] m s-1
        descent_rate_ms: 1                    # [0.1, 10] m s-1
        ground_before_s: 60                   # [0, 3600] s
        ground_after_s: 30                    # [0, 3600] s
        hover_margin_s: 30                    # [0, 600] s
        gnss_acquisition_s: 40                # [0, 1800] s
        gnss_blink_s: 3                       # [0, 9] s
        ekf_init_s: 5                         # [0, 600] s
        logger_clock_offset_s: -5400          # [-1e+09, 1e+09] s
        logger_clock_drift_ppm: 0             # [-500, 500] ppm
        sonic_ins_lag_low_s: -0.185           # [-1, 1] s, each flight's sonic-INS processing
        sonic_ins_lag_high_s: 0               # [-1, 1] s, lag drawn from its seed in [low, high]
                                              #   (Ghirardelli et al. 2025, Fig. 4); low = high
                                              #   fixes it (0, 0: none)
        defects:                            # per file, each key optional
          sonic:
            missing_rate: 0.001               # [0, 0.02] 1
            duplicate_rate: 0.0005            # [0, 0.02] 1
            out_of_order_rate: 0.0005         # [0, 0.02] 1
            out_of_range_rate: 0.0003         # [0, 0.02] 1
          ins: {...same keys...}
      mast:
        rate_hz: 10                           # [1, 60] Hz
        margin_s: 120                         # [0, 3600] s
        noise_ms: 0.01                        # [0, 1] m s-1
        temperature_noise_k: 0.01             # [0, 1] K
        temperature_offset_k: 0               # [-5, 5] K
        nan_rate: 0.0002                      # [0, 0.02] 1
        diag_rate: 0.0002                     # [0, 0.02] 1
        record_skip_rate: 1e-05               # [0, 0.01] 1
        # flow distortion by tower and boom (mast.flow_distortion; every mast sonic):
        boom_blockage_deficit: 0              # [0, 0.15] 1, horizontal-speed deficit for
                                              #   wind along the boom (x cos of the angle)
        tower_wake_deficit: 0                 # [0, 0.6] 1, deficit with the sonic in the
        tower_wake_half_width_deg: 30         # [5, 90] degree, tower wake (cos^2 sector)
        streamline_tilt_deg: 0                # [-10, 10] degree, upward turn of the flow
      payload_flights:                # one entry per manifest payload flight (required)
        s01:
          mean_speed_ms: 3.1          # (0, 40] at z_ref_m
          wind_from_deg: 97           # [0, 360]
          z_over_L: -0.46             # [-5, 5] at z_ref_m  (or obukhov_length_m: |L| >= 1 or inf)
          z_ref_m: 30                 # default: height of the flight's reference mast sonic
          hover_height_m: 28          # default: target_height_m (else the reference height)
          start: 2023-08-21T14:05:32Z # hover-window start; default: the flight's window.start
          duration_s: 1680            # hover-window length; default: window end - start
          flight_duration_s: 2100     # optional total log length; must hold the hover window
                                      #   + 2 hover margins + climb + descent + ground times
          hover_offset_enu_m: [25, -30]   # payload position relative to the reference mast;
                                      #   default 35 m right of the mast (looking downwind)
                                      #   and 10 m upwind
          sonic_ins_lag_s: -0.1       # [-2, 2] s, this flight's processing lag (time to add
                                      #   to the sonic clock); default: drawn in the payload's range
          roughness_length_m: 0.3     # overrides of the atmosphere block
          theta_mean_k: 299.0
          boundary_layer_height_m: 1500
          sonic_rate_hz: 20           # overrides of payload.sonic_rate_hz, payload.ins_rate_hz
          ins_rate_hz: 100            #   and mast.rate_hz for this flight (their ranges; a
          mast_rate_hz: 20            #   forward flight records at the measured rates)
      mechanisms:                     # list; empty or absent = baseline
        - mechanism: attitude_lag     # a name of dronewind.mechanisms.CATALOG
          parameters: {lag_s: 0.08}   # exactly the catalog's parameters, in range
          flights: [s05, s07]         # optional; default every flight (payload or quadrotor)

The turbulence-model and flow-distortion settings describe physics the diagnosis' forward
model does not have (model-error truths of :mod:`dronewind.diagnose.experiments`); the
mast flow distortion scales the horizontal wind by a direction-dependent factor, unlike
the catalog's ``mast_w_attenuation`` (a gain on w). Their defaults leave the simulation
bit-identical to a manifest without them.

``quadrotor_flights``, ``quadrotor`` and ``tunnel`` keys are reserved for the quadrotor
and tunnel simulators and not checked here. Unknown keys, missing conditions, values
out of range, an unknown mechanism or flight id, a mechanism listed twice for one flight
and a hover window longer than ``flight_duration_s`` raise
:class:`dronewind.errors.InputError` whose ``where`` is the key path
(``simulation.payload_flights.s03.mean_speed_ms``).

Output files of :func:`~dronewind.simulate.payload.simulate_payload_flight`: the
flight's ``sonic.file`` and ``ins.file`` under ``out_dir`` and, for every mast sonic,
``out_dir / <first files pattern containing '*'>.replace("*", flight_id)`` (TOA5; a
simulated campaign's mast globs must contain ``*``), covering the flight's log span
+- ``mast.margin_s``, clipped halfway to neighbouring flights so that the per-flight
files of one sonic never overlap in time.
"""

import importlib
from typing import Any

#: Public names re-exported lazily (PEP 562): a quadrotor or tunnel job importing its own
#: simulator does not pay for the payload simulator's imports.
_EXPORTS = {"simulate_wind": "atmosphere", "simulate_payload_flight": "payload"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"dronewind.simulate.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'dronewind.simulate' has no attribute {name!r}")
