"""The batch of ``VerticalVehicle-v1`` with ``backend="fmu"``: an FMU as the whole vehicle.

:class:`FMUVehicleBatch` is a :class:`~railgym.envs.vehicle.batch.VehicleBatch` whose control
step advances one FMU instance per sub-env (:class:`~railgym.fmu.runner.FMURunner`) instead
of the compiled kernel, then runs the same compiled bookkeeping
(:func:`~railgym.envs.vehicle.batch.book_step`: observation, reward with its Wk filter, info,
comfort record). Each wheelset's track input is the env's cubic Hermite interpolation of the
track at its offset (at the substeps' ends, and their midpoints for model exchange). The FMU's
outputs (deflections, their rates and the carbody velocities over the bogies) are written
into a state vector that gives them back through the kernels' formulas (carbody bounce and
pitch rates from the two velocities, positions 0 but the bogie bounce = deflection), so the
``"sensors"`` observation and the reward are those of the FMU; ``observation="full"`` needs
the vehicle's own states and is refused. ``out_of_domain`` stays 0; a non-finite output ends
the episode as a divergence. Not picklable (an FMU instance lives in it).
"""

from __future__ import annotations

import numpy as np

from railgym import _checks as val
from railgym.envs.params import TrackEnvParams
from railgym.envs.vehicle.batch import VehicleBatch, book_step
from railgym.fmu.mapping import Mapping
from railgym.fmu.runner import FMUInstances, FMURunner
from railgym.vehicles.vehicle.lanes import hermite
from railgym.vehicles.vehicle.model import Lpr
from railgym.vehicles.vehicle.params import WholeVehicle

__all__ = ["FMUVehicleBatch"]

_FLOOR = ("acc_front", "acc_centre", "acc_rear")
_BOGIE = ("bogie_acc_front", "bogie_acc_rear")


class FMUVehicleBatch(FMUInstances, VehicleBatch):
    """``n`` whole vehicles, each an instance of the FMU of ``mapping``."""

    def __init__(
        self,
        n: int,
        cfg: TrackEnvParams,
        vehicle: WholeVehicle,
        lpr: Lpr,
        v_min: float,
        mapping: Mapping,
    ) -> None:
        if cfg.obs_names[0] == "z_c":
            raise val.FieldError(
                "observation",
                "'full' needs the vehicle's states, which an FMU does not give: use "
                "observation='sensors' with backend='fmu'",
            )
        super().__init__(n, cfg, vehicle, lpr, v_min)
        self.mapping = mapping
        self.runners = [FMURunner(mapping, cfg.dt, cfg.n_sub) for _ in range(n)]
        keys = self.runners[0].out_keys
        self._cols = {k: keys.index(k) for k in keys}
        self._susp = vehicle.suspension.kernel_params()

    def _wheel_inputs(self, i: int) -> tuple[np.ndarray, ...]:
        """Track height and rate at the four wheelsets over the step (4, n_sub + 1) and at
        the substeps' midpoints (4, n_sub), as the kernel interpolates them."""
        arrays, dt, n_sub = self.arrays, self.cfg.dt, self.cfg.n_sub
        z, zd, off, k = arrays.z[i], arrays.zdot[i], arrays.off[i], int(arrays.k[i])
        s = int(arrays.start[i])
        w, wd = np.empty((4, n_sub + 1)), np.empty((4, n_sub + 1))
        wm, wdm = np.empty((4, n_sub)), np.empty((4, n_sub))
        for j in range(4):
            for m in range(n_sub + 1):
                w[j, m], wd[j, m] = hermite(z, zd, float(k + m) + off[j], dt, s)
            for m in range(n_sub):
                wm[j, m], wdm[j, m] = hermite(z, zd, (float(k + m) + 0.5) + off[j], dt, s)
        return w, wd, wm, wdm

    def advance(self) -> None:
        """One control step of every FMU with the stored actions, then the bookkeeping (chunked
        mode: the track windows moved first, as the compiled batch does)."""
        if self.window is not None:
            self._cover_step()
        arrays, out, book, c, p, e = (
            self.arrays,
            self.out,
            self.book,
            self._cols,
            self.params,
            self._susp,
        )
        for i, run in enumerate(self.runners):
            arrays.force[i] = book.action[i] * self.cfg.f_max
            w, wd, wm, wdm = self._wheel_inputs(i)
            y = run.advance(w, wd, arrays.force[i], mid=(wm, wdm))
            ok = bool(np.isfinite(y).all())
            out.count[i] = 0
            out.fs[i] = 0.0
            out.div[i] = not ok
            if not ok:
                out.acc[i] = 0.0
                continue
            last = y[-1]
            out.acc[i] = [last[c[k]] for k in (*_FLOOR, *_BOGIE)]
            for b, name in enumerate(("front", "rear")):
                if f"secondary_force_{name}" in c:
                    out.fs[i, b] = last[c[f"secondary_force_{name}"]]
                d = y[:, c[f"deflection_{name}"]]
                out.count[i, 0] += int(np.count_nonzero((d > e.free_c) | (d < -e.free_r)))
            x = arrays.state[i]
            x[:] = 0.0
            v_f, v_r = last[c["carbody_vel_front"]], last[c["carbody_vel_rear"]]
            x[7] = 0.5 * (v_f + v_r)
            x[8] = (v_f - v_r) / (2.0 * p.a) if p.a > 0.0 else 0.0
            for b, name in enumerate(("front", "rear")):
                xb = p.a if b == 0 else -p.a
                x[3 + 2 * b] = last[c[f"deflection_{name}"]]
                vel = x[7] + xb * x[8] + p.phi_a * x[9]
                x[10 + 2 * b] = last[c[f"deflection_rate_{name}"]] + vel
        book_step(arrays, p, out, book, self.step_consts)

    def close(self) -> None:
        """Free the FMU instances."""
        for run in self.runners:
            run.close()
