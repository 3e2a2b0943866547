"""``railgym/TrainCrash-v1``: the env (:mod:`.env`), its declared arguments (:mod:`.params`),
its batch (:mod:`.batch`) with the compiled step (:mod:`.step`) and the buffer layout
(:mod:`.layout`), and its frame (:mod:`.render`).

The package re-exports the env's public names (``railgym.envs.crash`` was one module).
"""

from railgym.envs.crash.env import *  # noqa: F403
from railgym.envs.crash.env import __all__  # noqa: F401
