"""Shadow the wrapped (surrogate) env with the high-fidelity reference model.

The paper judges a surrogate element by running the multi-body model with it and comparing
the carbody response with the original model's (section 3.4 and Table 5: eq. 9 average
absolute errors of the carbody displacement, velocity and acceleration, and the simulation
time T_s). :class:`ReferenceShadow` does this online: every step it applies the actuator
force the wrapped env just applied to a second env of the same class with
``backend="reference"``, riding the identical track, and reports running errors in
``info``; at the end of the episode ``info["shadow"]`` holds the summary.
"""

from __future__ import annotations

import time
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from railgym import _checks as val
from railgym.envs.vertical.env import ENV_BACKENDS, VerticalSuspensionEnv
from surrogates.metrics import average_absolute_error, paper_error

#: carbody channels compared: (info suffix, unit)
CHANNELS = (("disp", "m"), ("vel", "m/s"), ("acc", "m/s²"))


def _carbody(env: VerticalSuspensionEnv) -> tuple[float, float, float]:
    """Carbody displacement x2 (m), velocity v2 (m/s), acceleration ẍ2 (m/s²) of ``env``."""
    state = env.state
    return float(state[2]), float(state[3]), env.carbody_acceleration


def _shadow_of(
    base: VerticalSuspensionEnv, backend: str, vehicle: str | None, fmu: dict[str, Any]
) -> Any:
    """A ``backend`` env with every setting of ``base`` (same vehicle, steps, reward);
    ``fmu``: the ``fmu``/``fmu_map`` arguments of ``backend="fmu"``."""
    cfg = base.cfg
    if vehicle is None:
        vehicle = cfg.vehicle  # the vehicle the wrapped env runs (its file, name or object)
    shadow = VerticalSuspensionEnv(
        backend=backend,
        track_class=base.track_class,
        speed=base.speed,
        duration=cfg.duration,
        control_dt=cfg.control_dt,
        dt=cfg.dt,
        f_max=cfg.f_max,
        observation=cfg.observation,
        sensor_noise=cfg.sensor_noise,
        reward_weights=cfg.reward_weights,
        acc_weighting=cfg.acc_weighting,
        wheelbase=cfg.wheelbase,
        band=cfg.band,
        vehicle=vehicle,
        **fmu,
    )
    if not shadow.cfg.model.same_physics(cfg.model):
        raise ValueError(
            f"vehicle {vehicle!r} differs from the wrapped env's vehicle {cfg.vehicle!r}; "
            "pass the wrapped env's vehicle as vehicle="
        )
    return shadow


def compared_against(env: VerticalSuspensionEnv) -> str:
    """What a shadow ``env`` is, in words: the FMU (and its mapping) or railgym's model of
    the backend, with the vehicle it runs."""
    cfg = env.cfg
    vehicle = f"vehicle {cfg.model.name!r} ({cfg.vehicle})"
    if cfg.backend == "fmu":
        from railgym.envs.vertical.fmu_batch import FMUBatch

        assert isinstance(env.sim, FMUBatch)
        mapping = env.sim.mapping
        return f"the FMU {mapping.fmu} (mapping {mapping.source}), {vehicle}"
    model = {
        "reference": "railgym's reference model",
        "linear": "the linear suspension",
        "surrogate": "the surrogate element",
    }
    return f"{model[cfg.backend]} of {vehicle}"


class _TimedAdvance:
    """Stands in for ``sim.advance`` of a batch (an instance attribute, so the batch's own
    method runs unchanged): runs it and keeps its wall time, s, in :attr:`last`."""

    def __init__(self, sim: Any) -> None:
        self.sim = sim
        self.inner = sim.__dict__.get("advance")  # another stand-in already there, if any
        self.last = 0.0

    @classmethod
    def install(cls, sim: Any) -> _TimedAdvance:
        """Set a stand-in on ``sim``; returns it."""
        timer = cls(sim)
        sim.advance = timer
        return timer

    def __call__(self) -> None:
        sim, inner = self.sim, self.inner
        t0 = time.perf_counter()
        if inner is None:
            type(sim).advance(sim)
        else:
            inner()
        self.last = time.perf_counter() - t0

    def remove(self) -> None:
        """Put back what was there before :meth:`install`."""
        if self.sim.__dict__.get("advance") is self:
            if self.inner is None:
                del self.sim.advance
            else:
                self.sim.advance = self.inner


def _compared(model: str, reference: str, n_model: int, n_reference: int) -> str:
    """What ``speedup`` compared: the backends, their batch calls and the steps timed."""

    def call(backend: str) -> str:
        return "FMU calls through FMPy" if backend == "fmu" else "compiled per-env kernel"

    steps = f"{n_model}" if n_model == n_reference else f"{n_model} and {n_reference}"
    return (
        f"median time per control step in sim.advance, backend {reference!r} "
        f"({call(reference)}) over backend {model!r} ({call(model)}), over {steps} steps of "
        "this episode, one vehicle per call, Python shell excluded; not the lane kernel of "
        "vector envs"
    )


class ReferenceShadow(gym.Wrapper):
    """Run the reference model in lock-step with the wrapped env and report its errors.

    Parameters
    ----------
    env : a :class:`~railgym.envs.vertical.env.VerticalSuspensionEnv`, possibly wrapped (e.g. by
        ``gym.make``); any other env raises ``ValueError``.
    reference_backend : backend of the shadow env (default ``"reference"``, the
        high-fidelity model).
    vehicle : vehicle of the shadow; ``None``: the wrapped env's (``env.unwrapped.cfg.vehicle``).
        It must have the wrapped env's parameters, whatever its name (checked).
    fmu, fmu_map : with ``reference_backend="fmu"``: the FMU as the reference and its mapping
        file (``docs/fmi.md``).

    Notes
    -----
    After every ``reset`` the shadow gets a copy of the wrapped env's track arrays ``z``,
    ``ż``, class and speed, so both models ride the identical track. Each step the shadow
    receives the actuator force the wrapped env applied (``actuator_force / f_max``), so
    action-transforming wrappers inside this one are followed exactly.

    Speed is measured the same way on both sides: the wall time of each env's one batch
    call per control step (``sim.advance``: for the numba backends the compiled kernel, its
    argument unboxing included; for ``"fmu"`` the FMU calls through FMPy), timed by a
    stand-in for that call set on both batches while the wrapper is open (``close`` removes
    it). It excludes the Python shell around it (action check, ``info``, observation,
    gymnasium's wrappers): the same code for every backend, and most of a single-env step.

    ``info`` of every step adds ``shadow_err_disp`` (m), ``shadow_err_vel`` (m/s),
    ``shadow_err_acc`` (m/s²): running eq. 9 average absolute error ``mean_k |ŷ_k − y_k|``
    of the carbody displacement x2, velocity ẋ2 and acceleration ẍ2 over the steps so far
    (wrapped model ŷ, reference y, sampled at the control rate), and
    ``shadow_carbody_acc``, the reference ẍ2 (m/s²). At episode end ``info["shadow"]``
    holds:

    ``steps``; ``err_disp``, ``err_vel``, ``err_acc`` (eq. 9); ``paper_index``: per channel
    ``(value, "relative" | "absolute")`` chosen by the paper's rule (eq. 8 only when the
    reference output stays far from zero, :func:`surrogates.metrics.paper_error`);
    ``rms_acc_model``, ``rms_acc_reference`` (m/s²); ``out_of_domain`` (surrogate
    evaluations outside the training box); ``kernel_s_per_step_model``,
    ``kernel_s_per_step_reference``: the median over the episode's steps of the time in each
    batch's call (s; see above) and ``speedup``: ``kernel_s_per_step_reference /
    kernel_s_per_step_model``, the kernel speed-up of a single env (one vehicle per call;
    the surrogate's lane kernel, which vector envs of 8 or more sub-envs run, is faster per
    vehicle and not measured here: see ``railgym demo``); ``speedup_compared``: that
    comparison in words (backends, batch calls, steps timed); ``wall_time_model_s``,
    ``wall_time_reference_s``: the summed wall time of each side's ``step`` over the
    episode, Python shell included (the wrapped env's inner wrappers too, the shadow has
    none), so not a comparison of the models;
    ``model_diverged``, ``reference_diverged``; ``backend``, ``reference_backend``;
    ``reference``: what the shadow is, in words (the FMU and its mapping, or railgym's model,
    with the vehicle; also :attr:`compared_against`).
    If the shadow diverges first, it stops and the errors cover the steps before.
    """

    def __init__(
        self,
        env: gym.Env,
        reference_backend: str = "reference",
        vehicle: str | None = None,
        fmu: Any = None,
        fmu_map: Any = None,
    ) -> None:
        super().__init__(env)
        base = env.unwrapped
        if not isinstance(base, VerticalSuspensionEnv):
            raise ValueError(
                "env: ReferenceShadow supports railgym/VerticalSuspension-v1 "
                f"(VerticalSuspensionEnv) only, got {type(base).__name__}"
            )
        reference_backend = val.choice(reference_backend, "reference_backend", ENV_BACKENDS)
        self.base = base
        self.reference_backend = reference_backend
        given = {"fmu": fmu, "fmu_map": fmu_map}
        self.shadow = _shadow_of(
            base, reference_backend, vehicle, {k: v for k, v in given.items() if v is not None}
        )
        #: what the wrapped env is compared against, in words (:func:`compared_against`)
        self.compared_against = compared_against(self.shadow)
        n = base.cfg.n_steps
        self._trace = np.zeros((2, n, 3))  # [model, reference] × step × (x2, v2, ẍ2)
        self._kernel = np.zeros((2, n))  # [model, reference] × step: time in sim.advance, s
        self._timers = (_TimedAdvance.install(base.sim), _TimedAdvance.install(self.shadow.sim))
        self._clear()

    def _clear(self) -> None:
        self._n = self._n_model = 0
        self._abs_sum = np.zeros(3)
        self._time_model = self._time_ref = 0.0
        self._ref_done = self._ref_diverged = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the wrapped env, then the shadow onto a copy of its track."""
        obs, info = self.env.reset(seed=seed, options=options)
        base, shadow = self.base, self.shadow
        shadow.reset(seed=seed, options={"track_class": base.track_class, "speed": base.speed})
        shadow.reset_on_track(base)
        self._clear()
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the wrapped env, then the shadow with the force it applied."""
        t0 = time.perf_counter()
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._time_model += time.perf_counter() - t0
        self._kernel[0, self._n_model] = self._timers[0].last
        self._n_model += 1
        base = self.base
        if not self._ref_done:
            u = np.array([base.actuator_force / base.cfg.f_max])
            t0 = time.perf_counter()
            _, _, s_term, s_trunc, _ = self.shadow.step(u)
            self._time_ref += time.perf_counter() - t0
            self._ref_done, self._ref_diverged = s_term or s_trunc, s_term
            k = self._n
            self._kernel[1, k] = self._timers[1].last
            self._trace[0, k] = _carbody(base)
            self._trace[1, k] = _carbody(self.shadow)
            self._abs_sum += np.abs(self._trace[0, k] - self._trace[1, k])
            self._n = k + 1
        errors = self._abs_sum / self._n
        for (name, _), e in zip(CHANNELS, errors, strict=True):
            info[f"shadow_err_{name}"] = float(e)
        info["shadow_carbody_acc"] = self.shadow.carbody_acceleration
        if terminated or truncated:
            info["shadow"] = self._summary(model_diverged=bool(terminated), info=info)
        return obs, reward, terminated, truncated, info

    def _summary(self, model_diverged: bool, info: dict[str, Any]) -> dict[str, Any]:
        """Episode indices so far (see the class notes for the keys)."""
        n = self._n
        model, ref = self._trace[0, :n], self._trace[1, :n]
        out: dict[str, Any] = {"steps": n}
        for j, (name, _) in enumerate(CHANNELS):
            out[f"err_{name}"] = average_absolute_error(model[:, j], ref[:, j])
        out["paper_index"] = {
            name: paper_error(model[:, j], ref[:, j]) for j, (name, _) in enumerate(CHANNELS)
        }
        out["rms_acc_model"] = float(np.sqrt(np.mean(model[:, 2] ** 2)))
        out["rms_acc_reference"] = float(np.sqrt(np.mean(ref[:, 2] ** 2)))
        out["out_of_domain"] = int(info.get("out_of_domain", self.base.out_of_domain))
        k_model = float(np.median(self._kernel[0, : self._n_model]))
        k_ref = float(np.median(self._kernel[1, :n]))
        out["kernel_s_per_step_model"] = k_model
        out["kernel_s_per_step_reference"] = k_ref
        out["speedup"] = k_ref / k_model if k_model > 0 else np.nan
        out["speedup_compared"] = _compared(
            self.base.backend, self.reference_backend, self._n_model, n
        )
        out["wall_time_model_s"] = self._time_model
        out["wall_time_reference_s"] = self._time_ref
        out["model_diverged"] = model_diverged
        out["reference_diverged"] = self._ref_diverged
        out["backend"] = self.base.backend
        out["reference_backend"] = self.reference_backend
        out["reference"] = self.compared_against
        return out

    def close(self) -> None:
        """Remove the timing stand-ins, close the shadow and the wrapped env."""
        for timer in self._timers:
            timer.remove()
        self.shadow.close()
        super().close()
