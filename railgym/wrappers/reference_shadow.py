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
from typing import Any

import gymnasium as gym
import numpy as np

from railgym import _checks as val
from railgym.envs.vertical import ENV_BACKENDS, VerticalSuspensionEnv
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
    if vehicle is None:
        spec = base.spec
        vehicle = spec.kwargs.get("vehicle", "manchester") if spec is not None else "manchester"
    cfg = base.cfg
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
    if shadow.vehicle_params != base.vehicle_params:
        raise ValueError(
            f"vehicle {vehicle!r} differs from the wrapped env's vehicle; pass the wrapped "
            "env's vehicle as vehicle="
        )
    return shadow


class ReferenceShadow(gym.Wrapper):
    """Run the reference model in lock-step with the wrapped env and report its errors.

    Parameters
    ----------
    env : a :class:`~railgym.envs.vertical.VerticalSuspensionEnv`, possibly wrapped (e.g. by
        ``gym.make``); any other env raises ``ValueError``.
    reference_backend : backend of the shadow env (default ``"reference"``, the
        high-fidelity model).
    vehicle : vehicle of the shadow; ``None`` takes it from ``env.spec`` (``gym.make``) or
        the default. It must have the wrapped env's parameters (checked).
    fmu, fmu_map : with ``reference_backend="fmu"``: the FMU as the reference and its mapping
        file (``docs/fmi.md``).

    Notes
    -----
    After every ``reset`` the shadow gets a copy of the wrapped env's track arrays ``z``,
    ``ż``, class and speed, so both models ride the identical track. Each step the shadow
    receives the actuator force the wrapped env applied (``actuator_force / f_max``), so
    action-transforming wrappers inside this one are followed exactly.

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
    evaluations outside the training box); ``wall_time_model_s``, ``wall_time_reference_s``
    (the paper's T_s per episode: ``time.perf_counter`` around each model's ``step``, the
    wrapped env's inner wrappers included) and ``speedup`` (reference / model);
    ``model_diverged``, ``reference_diverged``; ``backend``, ``reference_backend``.
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
        n = base.cfg.n_steps
        self._trace = np.zeros((2, n, 3))  # [model, reference] × step × (x2, v2, ẍ2)
        self._clear()

    def _clear(self) -> None:
        self._n = 0
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

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the wrapped env, then the shadow with the force it applied."""
        t0 = time.perf_counter()
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._time_model += time.perf_counter() - t0
        base = self.base
        if not self._ref_done:
            u = np.array([base.actuator_force / base.cfg.f_max])
            t0 = time.perf_counter()
            _, _, s_term, s_trunc, _ = self.shadow.step(u)
            self._time_ref += time.perf_counter() - t0
            self._ref_done, self._ref_diverged = s_term or s_trunc, s_term
            k = self._n
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
        out["wall_time_model_s"] = self._time_model
        out["wall_time_reference_s"] = self._time_ref
        out["speedup"] = self._time_ref / self._time_model if self._time_model > 0 else np.nan
        out["model_diverged"] = model_diverged
        out["reference_diverged"] = self._ref_diverged
        out["backend"] = self.base.backend
        out["reference_backend"] = self.reference_backend
        return out

    def close(self) -> None:
        """Close the shadow and the wrapped env."""
        self.shadow.close()
        super().close()
