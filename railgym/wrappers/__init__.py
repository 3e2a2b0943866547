"""Gymnasium wrappers of railgym: evaluation indices computed alongside any episode.

- :class:`ReferenceShadow` — steps the high-fidelity reference model in lock-step with a
  surrogate env on the same track and reports the paper's accuracy and time indices
  (section 3.4: eq. 9 errors, simulation time T_s);
- :class:`RideComfort` — ISO 2631-1 weighted r.m.s. acceleration and Sperling's Wz, with an
  optional comfort reward term;
- :class:`CrashSafety` — per-car deceleration, per-zone absorbed energy and stroke used of a
  crash episode.
"""

from railgym.wrappers.crash_safety import CrashSafety
from railgym.wrappers.reference_shadow import ReferenceShadow
from railgym.wrappers.ride_comfort import RideComfort

__all__ = ["CrashSafety", "ReferenceShadow", "RideComfort"]
