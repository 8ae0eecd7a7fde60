"""An independent simulated world that writes measured campaigns for the diagnosis to judge.

Nothing here is imported by ``src/dronewind``, and nothing here imports
``dronewind.simulate``: the world's physics is its own, so that the diagnosis, tuned on
the project's simulator, is tested against a campaign it did not write.

* :mod:`.turbulence`: one Mann (1994) turbulence box per flight (hipersim) holding the mast
  sonic and the hovering payload, advected past both by Taylor's hypothesis; mean wind
  from a log profile with the Högström (1988) stability correction.
* :mod:`.pendulum`: the payload on a line under a position-holding drone, with quadratic
  drag on the payload and distributed drag on the line, and a yaw degree of freedom,
  integrated by :func:`scipy.integrate.solve_ivp`.
* :mod:`.ins`: an aided INS with gyro-bias random walks, Gauss-Markov velocity errors,
  position noise and a GNSS time that blinks valid before it settles.
* :mod:`.files`: the contract's L0 files (payload sonic CSV, INS CSV, Campbell TOA5) and
  a manifest without ``simulation:``.
* :mod:`.campaign`: truths (null, catalog mechanisms, model errors) and the campaign writer.
"""

from tests.worlds.campaign import (
                                   HIDDEN_MECHANISMS,
                                   WORLD_MODEL_ERRORS,
                                   WorldSettings,
                                   stratified_world_draws,
                                   write_campaign,
)

__all__ = ["HIDDEN_MECHANISMS", "WORLD_MODEL_ERRORS", "WorldSettings", "stratified_world_draws", "write_campaign"]
