"""The batch of ``VerticalSuspension-v1`` with ``backend="fmu"``: an FMU as the vehicle model.

:class:`FMUBatch` is a :class:`~railgym.envs.vertical.batch.VerticalBatch` whose control step
advances one FMU instance per sub-env (:class:`~railgym.fmu.runner.FMURunner`) instead of the
compiled kernel; observation, reward, its terms, ``info`` and the episode flags come from the
same compiled bookkeeping as the other backends. The FMU's outputs fill the state as
``[x2 + δ, v2 + δ̇, x2, v2, 0, 0, 0]`` (``x2`` from ``carbody_disp``, 0 when not mapped);
``bump_stop_contacts`` counts substeps with δ beyond the vehicle's free travel, as the
kernels do; ``out_of_domain`` stays 0. A non-finite FMU output ends the episode as a
divergence. The batch cannot be copied or pickled (an FMU instance lives in it).
"""

from __future__ import annotations

import numpy as np

from railgym.envs.params import TrackEnvParams
from railgym.envs.vertical.batch import VerticalBatch, post_step
from railgym.fmu.mapping import Mapping
from railgym.fmu.runner import FMUInstances, FMURunner
from railgym.vehicles.vertical.elements import LprArrays
from railgym.vehicles.vertical.params import VerticalVehicle

__all__ = ["FMUBatch"]


class FMUBatch(FMUInstances, VerticalBatch):
    """``n`` vertical vehicles, each an instance of the FMU of ``mapping``."""

    def __init__(
        self,
        n: int,
        cfg: TrackEnvParams,
        vehicle: VerticalVehicle,
        lpr: LprArrays,
        mapping: Mapping,
    ) -> None:
        super().__init__(n, cfg, vehicle, lpr)
        self.mapping = mapping
        self.runners = [FMURunner(mapping, cfg.dt, cfg.n_sub) for _ in range(n)]
        keys = self.runners[0].out_keys
        self._cols = {k: keys.index(k) for k in keys}

    def advance(self) -> None:
        """One control step of every FMU with the stored actions (chunked mode: the windows
        moved first, as the compiled batch does)."""
        if self.window is not None:
            self._cover_step()
        c, p = self._cols, self.params
        n_sub = self.cfg.n_sub
        for i, run in enumerate(self.runners):
            self.force[i] = self.actions[i, 0] * self.cfg.f_max
            k = int(self.k[i])
            y = run.advance(
                self.z[i : i + 1, k : k + n_sub + 1],
                self.zdot[i : i + 1, k : k + n_sub + 1],
                self.force[i : i + 1],
            )
            last = y[-1]
            ok = bool(np.isfinite(y).all())
            if ok:
                d, dd, v2 = (
                    last[c["deflection"]],
                    last[c["deflection_rate"]],
                    last[c["carbody_vel"]],
                )
                x2 = last[c["carbody_disp"]] if "carbody_disp" in c else 0.0
                self.state[i, :4] = (x2 + d, v2 + dd, x2, v2)
                self.acc[i] = (last[c["bogie_acc"]], last[c["carbody_acc"]])
                defl = y[:, c["deflection"]]
                self.count[i, 0] = int(np.count_nonzero((defl > p.free_c) | (defl < -p.free_r)))
            else:
                self.acc[i] = 0.0
                self.count[i, 0] = 0
            self.fs[i] = 0.0
            self.count[i, 1] = 0
            self.div[i] = not ok
        post_step(
            self.state,
            self.z,
            self.zdot,
            self.out,
            self.force,
            self.cnt,
            self.res,
            self.step_consts,
        )

    def close(self) -> None:
        """Free the FMU instances."""
        for run in self.runners:
            run.close()
