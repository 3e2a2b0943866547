"""A trained policy as a standalone FMI 2.0 co-simulation FMU in C, and as ONNX.

``railgym export-policy POLICY -o controller.fmu [--onnx controller.onnx]``: the SB3 MLP
policy (PPO or SAC, as :mod:`agents.training.train` writes them; ``POLICY`` a zip with its
``config.yaml`` beside it or a pretrained name of :mod:`agents.policies.pretrained`, resolved as
``railgym evaluate`` does) is loaded as weights only, after the manifest check
(:func:`agents.policies.loading.load_policy`); its deterministic action is written out as plain C
(``agents/c/policy_element.h`` on the generic FMI element of ``surrogates/fmi/c/element.c``)
with no Python in the host:

* inputs: the env's observation channels in SI, named after ``obs_names``, in its order;
* inside: the env's observation scaling (``obs / obs_scale``, rounded to float32 as the env
  does), the MLP (float32 weights, double sums), SAC's ``tanh`` squashing, the clipping of
  the action space, and ``force = action · f_max``;
* outputs: the actuator forces in N (``actuator_force``; ``actuator_force_front``,
  ``actuator_force_rear`` for ``VerticalVehicle-v1``).

A residual policy (config ``residual``, :mod:`agents.controllers.residual`) also holds its classical
base, designed for the training case as where the policy is loaded, as a linear discrete
state-space (:mod:`agents.policies.residual_export`, ``agents/c/linear_base.h``): the force is
``clip(a_base + scale·a_policy, −1, 1)·f_max``, and the base's state (an LQG's Kalman
estimate) is updated at each ``fmi2DoStep`` and back at rest at ``fmi2Reset`` and
instantiation. Policies that decide every ``action_hold > 1`` steps, crash-env policies (their
action is an absorber force scale, not a force) and non-linear bases are refused, saying why.

The ONNX graph computes the same from a ``(batch, n_obs)`` double input ``observation`` to
a ``(batch, n_act)`` float output ``actuator_force`` (needs the ``onnx`` extra); with a base
that has states, also from the input ``controller_state`` (batch, n_x + n_act; zeros at an
episode start) to the output ``controller_state_out``, to be fed back at the next step.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.policies.residual_export import LinearBase, base_lines, base_onnx_nodes, linear_base
from surrogates.fmi.export import guid_of, identifier, template, write_fmu
from surrogates.fmi.model_description import Variable, model_description

__all__ = ["PolicyNet", "export_policy", "policy_net"]

#: activation module name → code of ``policy_element.h``
ACTIVATIONS = {"Identity": 0, "Tanh": 1, "ReLU": 2}
#: SI unit of the observation channels by name (VerticalVehicle-v1: by prefix, below)
UNITS = {
    "carbody_acc": "m/s2",
    "bogie_acc": "m/s2",
    "deflection": "m",
    "deflection_rate": "m/s",
    "carbody_vel": "m/s",
    "x1": "m",
    "v1": "m/s",
    "x2": "m",
    "v2": "m/s",
    "z": "m",
    "zdot": "m/s",
}


@dataclass(frozen=True)
class PolicyNet:
    """A policy's deterministic action as plain arrays, with the env's scalings."""

    weights: list[np.ndarray]  #: float32 (out, in) per layer
    biases: list[np.ndarray]  #: float32 (out,) per layer
    activations: list[str]  #: per layer, keys of :data:`ACTIVATIONS`
    squash: bool  #: SAC: ``tanh`` then the action space's affine map
    low: np.ndarray  #: action space bounds
    high: np.ndarray
    obs_names: tuple[str, ...]
    obs_scale: np.ndarray  #: SI value of one observation unit per channel
    f_max: float  #: actuator force at action 1, N

    def forces(self, obs_si: np.ndarray) -> np.ndarray:
        """Actuator forces (batch, n_act), N, from observations (batch, n_obs) in SI: the
        arithmetic of the C code in numpy."""
        x = (np.asarray(obs_si, float) * (1.0 / self.obs_scale)).astype(np.float32)
        x = x.astype(float)
        for w, b, act in zip(self.weights, self.biases, self.activations, strict=True):
            x = x @ w.astype(float).T + b.astype(float)
            x = np.tanh(x) if act == "Tanh" else np.maximum(x, 0.0) if act == "ReLU" else x
        if self.squash:
            x = self.low + 0.5 * (np.tanh(x) + 1.0) * (self.high - self.low)
        return np.clip(np.clip(x, self.low, self.high), -1.0, 1.0) * self.f_max


def _layers(modules: list[Any], where: str) -> tuple[list, list, list]:
    """Weights, biases and activations of a chain of Linear and activation modules."""
    ws, bs, acts = [], [], []
    for mod in modules:
        name = type(mod).__name__
        if name == "Linear":
            ws.append(mod.weight.detach().cpu().numpy().astype(np.float32))
            bias = mod.bias
            out = mod.weight.shape[0]
            bs.append(
                np.zeros(out, np.float32)
                if bias is None
                else bias.detach().cpu().numpy().astype(np.float32)
            )
            acts.append("Identity")
        elif name in ACTIVATIONS and ws:
            if acts[-1] != "Identity":
                raise ValueError(f"{where}: two activations in a row are not supported")
            acts[-1] = name
        else:
            raise ValueError(
                f"{where}: layer {name} is not supported (Linear with {sorted(ACTIVATIONS)})"
            )
    return ws, bs, acts


def policy_net(net: Any, env: Any) -> PolicyNet:
    """:class:`PolicyNet` of an SB3 ``ActorCriticPolicy`` (PPO, A2C) or SAC/TD3 policy on the
    (unwrapped) env ``env``, whose ``obs_names``, ``obs_scale`` and ``cfg.f_max`` it takes."""
    import torch

    kind = type(net).__name__
    extractor = getattr(net, "features_extractor", None) or getattr(
        getattr(net, "actor", None), "features_extractor", None
    )
    if type(extractor).__name__ != "FlattenExtractor":
        raise ValueError(f"policy {kind}: only MLP policies (FlattenExtractor) are exported")
    if getattr(net, "use_sde", False):
        raise ValueError(f"policy {kind}: gSDE policies are not supported")
    if hasattr(net, "mlp_extractor") and hasattr(net, "action_net"):
        modules = [*net.mlp_extractor.policy_net, net.action_net]
        squash = False
    elif hasattr(net, "actor") and hasattr(net.actor, "latent_pi"):
        modules = [*net.actor.latent_pi, net.actor.mu]
        squash = True
    elif hasattr(net, "actor") and isinstance(net.actor.mu, torch.nn.Sequential):
        modules, squash = list(net.actor.mu), False  # TD3: the final Tanh is in mu
    else:
        raise ValueError(f"policy {kind}: not a PPO, SAC or TD3 MLP policy")
    ws, bs, acts = _layers(modules, f"policy {kind}")
    space = net.action_space
    if getattr(net, "normalize_images", False) and len(env.observation_space.shape) != 1:
        raise ValueError(f"policy {kind}: the observation must be a vector")
    if not hasattr(env.cfg, "f_max"):
        raise ValueError(
            f"policy {kind}: the env {type(env).__name__} has no actuator force f_max (its "
            "action is not a force), and the FMU outputs actuator forces"
        )
    return PolicyNet(
        ws,
        bs,
        acts,
        squash,
        np.asarray(space.low, float),
        np.asarray(space.high, float),
        tuple(env.obs_names),
        np.asarray(env.obs_scale, float),
        float(env.cfg.f_max),
    )


def unit_of(name: str) -> str:
    """SI unit of an observation channel of the vertical envs (``""`` when not known)."""
    if name in UNITS:
        return UNITS[name]
    for prefix, unit in (
        ("acc_", "m/s2"),
        ("bogie_acc_", "m/s2"),
        ("deflection_rate_", "m/s"),
        ("deflection_", "m"),
        ("carbody_vel_", "m/s"),
    ):
        if name.startswith(prefix):
            return unit
    return ""


def _c_floats(a: np.ndarray) -> str:
    return ", ".join(f"{float(x)!r}f" if np.isfinite(x) else "0.0f" for x in a)


def _data_header(p: PolicyNet, guid: str, names: list[str], base: LinearBase | None) -> str:
    sizes = [p.weights[0].shape[1]] + [w.shape[0] for w in p.weights]
    offsets, params, at = [], [], 0
    for w, b in zip(p.weights, p.biases, strict=True):
        offsets.append(at)
        params.extend([w.ravel(), b])
        at += w.size + b.size
    flat = np.concatenate(params).astype(np.float32)
    d = lambda a: ", ".join(repr(float(x)) for x in a)  # noqa: E731
    return "\n".join(
        [
            "/* generated by agents.policies.policy_fmu: one trained policy */",
            f'#define EL_GUID "{guid}"',
            f"#define PL_NIN {sizes[0]}",
            f"#define PL_NOUT {sizes[-1]}",
            f"#define PL_NL {len(p.weights)}",
            f"#define PL_MAXW {max(sizes)}",
            f"#define PL_SQUASH {int(p.squash)}",
            f"#define PL_FMAX {p.f_max!r}",
            "static const int pl_sizes[PL_NL + 1] = {" + ", ".join(map(str, sizes)) + "};",
            "static const int pl_act[PL_NL] = {"
            + ", ".join(str(ACTIVATIONS[a]) for a in p.activations)
            + "};",
            "static const int pl_offset[PL_NL] = {" + ", ".join(map(str, offsets)) + "};",
            f"static const float pl_param[{flat.size}] = {{{_c_floats(flat)}}};",
            f"static const double pl_inv_scale[PL_NIN] = {{{d(1.0 / p.obs_scale)}}};",
            f"static const double pl_low[PL_NOUT] = {{{d(p.low)}}};",
            f"static const double pl_high[PL_NOUT] = {{{d(p.high)}}};",
            "static const double el_start[PL_NIN] = {" + ", ".join(["0.0"] * sizes[0]) + "};",
            "static const char *const el_input_names[PL_NIN] = {"
            + ", ".join(f'"{n}"' for n in names)
            + "};",
            *(base_lines(base) if base is not None else []),
            '#include "policy_element.h"',
            "",
        ]
    )


def force_names(n: int) -> list[str]:
    """Output names: ``actuator_force``; ``actuator_force_front``, ``_rear`` (the whole
    vehicle's two bogies); else ``actuator_force_1 … _n``."""
    if n == 1:
        return ["actuator_force"]
    if n == 2:
        return ["actuator_force_front", "actuator_force_rear"]
    return [f"actuator_force_{k + 1}" for k in range(n)]


def write_policy_fmu(
    p: PolicyNet,
    path: Path,
    label: str,
    compiler: str | None = None,
    base: LinearBase | None = None,
) -> Path:
    """Write the FMU of :class:`PolicyNet` ``p`` to ``path`` (co-simulation); with ``base``,
    of the residual policy whose network ``p`` is."""
    n_act = p.weights[-1].shape[0]
    doc = {
        "policy": label,
        "obs_names": list(p.obs_names),
        "obs_scale": p.obs_scale.tolist(),
        "f_max": p.f_max,
        "layers": [
            [w.tolist(), b.tolist(), a]
            for w, b, a in zip(p.weights, p.biases, p.activations, strict=True)
        ],
        "squash": p.squash,
        "low": p.low.tolist(),
        "high": p.high.tolist(),
    }
    if base is not None:
        doc["residual"] = base.document()
    text = json.dumps(doc, sort_keys=True)
    guid = guid_of(text)
    ident = identifier(path, None)
    names = list(p.obs_names)
    inputs = [
        Variable(n, unit_of(n), f"observation channel {n} (SI; the env's obs × {float(s)!r})")
        for n, s in zip(names, p.obs_scale, strict=True)
    ]
    # numbers as float repr: a numpy scalar's repr is `np.float64(…)`
    scale = None if base is None else float(base.scale)
    action = "action" if base is None else f"clip({base.name} + {scale!r}·policy, −1, 1)"
    outputs = [
        Variable(n, "N", f"actuator force {k + 1} = {action} × f_max ({float(p.f_max)!r} N)")
        for k, n in enumerate(force_names(n_act))
    ]
    what = "" if base is None else f" (residual of {base.name}, scale {scale!r})"
    xml = model_description(
        model_identifier=ident,
        guid=guid,
        description=f"railgym controller: policy {label}{what}, deterministic action as force",
        inputs=inputs,
        outputs=outputs,
        starts=[0.0] * len(names),
        kinds=("cs",),
        source_files=("element.c",),
    )
    c_files = resources.files("agents") / "c"
    sources = {
        "element_data.h": _data_header(p, guid, names, base),
        "policy_element.h": (c_files / "policy_element.h").read_text(),
        "element.c": template("element.c"),
    }
    if base is not None:
        sources["linear_base.h"] = (c_files / "linear_base.h").read_text()
    return write_fmu(
        path,
        ident,
        xml,
        sources,
        {"policy.json": text + "\n"},
        ("element.c",),
        binary=True,
        compiler=compiler,
    )


def _network_onnx_nodes(p: PolicyNet, const: Callable[[str, np.ndarray], str]) -> list[Any]:
    """ONNX nodes of :class:`PolicyNet` ``p`` from the graph input ``observation`` (double)
    to ``action`` (float32, clipped to ``[max(low, −1), min(high, 1)]``); ``const(name,
    array)`` adds an initializer."""
    from onnx import TensorProto, helper

    nodes = [
        helper.make_node(
            "Mul", ["observation", const("inv_scale", 1.0 / p.obs_scale)], ["obs_scaled"]
        ),
        helper.make_node("Cast", ["obs_scaled"], ["x0"], to=TensorProto.FLOAT),
    ]
    x = "x0"
    for k, (w, b, act) in enumerate(zip(p.weights, p.biases, p.activations, strict=True)):
        wt = const(f"w{k}", np.ascontiguousarray(w.T))
        nodes.append(helper.make_node("MatMul", [x, wt], [f"m{k}"]))
        nodes.append(helper.make_node("Add", [f"m{k}", const(f"b{k}", b)], [f"h{k}"]))
        x = f"h{k}"
        if act != "Identity":
            nodes.append(helper.make_node(act.replace("ReLU", "Relu"), [x], [f"a{k}"]))
            x = f"a{k}"
    f32 = np.float32
    if p.squash:
        nodes += [
            helper.make_node("Tanh", [x], ["sq_t"]),
            helper.make_node("Add", ["sq_t", const("one", np.ones(1, f32))], ["sq_1"]),
            helper.make_node(
                "Mul", ["sq_1", const("half_range", (0.5 * (p.high - p.low)).astype(f32))], ["sq_m"]
            ),
            helper.make_node("Add", ["sq_m", const("low_sq", p.low.astype(f32))], ["sq"]),
        ]
        x = "sq"
    low = np.maximum(p.low, -1.0).astype(f32)
    high = np.minimum(p.high, 1.0).astype(f32)
    nodes += [
        helper.make_node("Max", [x, const("low", low)], ["lo"]),
        helper.make_node("Min", ["lo", const("high", high)], ["action"]),
    ]
    return nodes


def write_policy_onnx(p: PolicyNet, path: Path, base: LinearBase | None = None) -> Path:
    """Write the ONNX graph of :class:`PolicyNet` ``p`` (needs the ``onnx`` extra); with
    ``base``, of the residual policy whose network ``p`` is (module docstring)."""
    try:
        import onnx
        from onnx import TensorProto, helper, numpy_helper
    except ImportError as err:
        raise ValueError(f"--onnx needs the 'onnx' extra (pip install onnx): {err}") from None
    n_obs, n_act = len(p.obs_names), p.weights[-1].shape[0]
    inits = []

    def const(name: str, value: np.ndarray) -> str:
        inits.append(numpy_helper.from_array(np.ascontiguousarray(value), name))
        return name

    nodes = _network_onnx_nodes(p, const)
    action, state_out = "action", None
    if base is not None:  # clip(a_base + scale·a_policy, −1, 1), rounded to float32
        base_nodes, base_action, state_out = base_onnx_nodes(base, const, "x0")
        nodes += base_nodes
        nodes += [
            helper.make_node("Cast", ["action"], ["agent"], to=TensorProto.DOUBLE),
            helper.make_node("Mul", ["agent", const("rscale", np.full(1, base.scale))], ["sa"]),
            helper.make_node("Add", [base_action, "sa"], ["sum"]),
            helper.make_node("Max", ["sum", const("sum_lo", -np.ones(1))], ["sum_l"]),
            helper.make_node("Min", ["sum_l", const("sum_hi", np.ones(1))], ["total"]),
            helper.make_node("Cast", ["total"], ["total32"], to=TensorProto.FLOAT),
        ]
        action = "total32"
    nodes.append(
        helper.make_node(
            "Mul", [action, const("f_max", np.full(1, p.f_max, np.float32))], ["actuator_force"]
        )
    )
    ins = [helper.make_tensor_value_info("observation", TensorProto.DOUBLE, ["batch", n_obs])]
    outs = [helper.make_tensor_value_info("actuator_force", TensorProto.FLOAT, ["batch", n_act])]
    doc = f"observation: the env's channels in SI ({', '.join(p.obs_names)}); actuator_force: N"
    if base is not None and state_out is not None:
        shape = ["batch", base.n_x + n_act]
        ins.append(helper.make_tensor_value_info("controller_state", TensorProto.DOUBLE, shape))
        outs.append(helper.make_tensor_value_info(state_out, TensorProto.DOUBLE, shape))
        doc += (
            f"; controller_state: the {base.name} base's state [estimate, last force N] "
            "(zeros at an episode start), its next value in controller_state_out"
        )
    graph = helper.make_graph(nodes, "railgym_policy", ins, outs, inits, doc_string=doc)
    model = helper.make_model(
        graph, producer_name="railgym", opset_imports=[helper.make_opsetid("", 17)]
    )
    model.ir_version = 8
    onnx.checker.check_model(model)
    path.write_bytes(model.SerializeToString())
    return path


#: env families whose policies the FMU exports (their action is an actuator force)
FORCE_ENVS = ("railgym/VerticalSuspension", "railgym/VerticalVehicle")


def _policy_zip(policy: str | Path) -> tuple[Path, Path, str | None]:
    """``(zip, config.yaml, pretrained name or None)`` of ``policy``: a pretrained name of
    :mod:`agents.policies.pretrained` (before a path, as in
    :func:`agents.policies.loading.load_policy`) or a zip with the ``config.yaml`` of its training
    beside it."""
    from agents.policies.pretrained import PRETRAINED, pretrained_zip

    name = str(policy)
    if name in PRETRAINED:
        path = pretrained_zip(name, PRETRAINED[name])
        return path, path.parent / "config.yaml", name
    path = Path(policy)
    cfg_path = path.parent / "config.yaml"
    if path.suffix != ".zip" or not path.is_file() or not cfg_path.is_file():
        raise ValueError(
            f"policy must be a pretrained name (one of {sorted(PRETRAINED)}) or a "
            "stable-baselines3 .zip with the config.yaml of its training beside it, got "
            f"{name!r}"
        )
    return path, cfg_path, None


def _check_exportable(cfg: Any, where: str) -> None:
    """ValueError naming ``where`` (the policy) and every reason the FMU cannot reproduce
    the policy of the config ``cfg``, in one line."""
    from railgym.registration import env_family

    reasons = []
    if env_family(cfg.env_id) not in FORCE_ENVS:
        what = (
            "sets the crash absorbers' force scale"
            if env_family(cfg.env_id) == "railgym/TrainCrash"
            else "is not one"
        )
        reasons.append(
            f"a {cfg.env_id} policy's action {what}, not an actuator force (the FMU outputs "
            "the actuator forces of VerticalSuspension and VerticalVehicle policies)"
        )
    if cfg.env_kwargs.get("actuator") == "semi-active":
        reasons.append(
            "its action is a damper command in [0, 1] (actuator: semi-active), not an actuator "
            "force, and its base's force demand goes through the damper model"
        )
    if cfg.action_hold > 1:
        reasons.append(f"action_hold is {cfg.action_hold}, but the FMU decides at every step")
    if reasons:
        raise ValueError(f"{where} cannot be exported: " + "; ".join(reasons))


def _check_base(base: LinearBase, p: PolicyNet, where: str) -> None:
    """The base and the network share the env's observation and ``f_max``."""
    n_act, n_obs = p.weights[-1].shape[0], len(p.obs_names)
    same = base.f_max == p.f_max and np.array_equal(base.obs_scale, p.obs_scale)
    if not same or base.g.shape != (n_act, n_obs):
        raise ValueError(
            f"{where}: the {base.name} base (f_max {base.f_max!r} N, {base.g.shape[1]} "
            f"observations) does not match the policy's env (f_max {p.f_max!r} N, {n_obs})"
        )


def export_policy(
    policy: str | Path,
    path: str | Path,
    onnx: str | Path | None = None,
    *,
    trust: bool = False,
    overwrite: bool = False,
    compiler: str | None = None,
) -> tuple[Path, Path | None]:
    """Write the policy ``policy`` as an FMU at ``path`` and optionally as ONNX: a pretrained
    name (``ppo-vertical``, ``ppo-vehicle``) or a zip with ``config.yaml`` and
    ``manifest.json`` beside it, as :mod:`agents.training.train` writes them.

    The env and its settings (observation, ``f_max``) are the config's; a residual policy
    brings its base, designed for the training case (module docstring). ``trust`` loads a
    zip the manifest does not list (see :func:`agents.policies.loading.load_policy`).
    """
    from agents.controllers.residual import ResidualPolicy
    from agents.policies.loading import design_env_kwargs, load_policy
    from agents.training.train_config import load_config

    path = Path(path)
    outs = [path] + ([Path(onnx)] if onnx is not None else [])
    for out, suffix in zip(outs, (".fmu", ".onnx"), strict=False):
        if out.suffix != suffix:
            flag = "-o/--out" if suffix == ".fmu" else "--onnx"
            raise ValueError(f"{flag} {str(out)!r}: the output must end in {suffix}")
        if out.exists() and not overwrite:
            raise FileExistsError(f"{out} exists; pass --overwrite to replace it")
    zip_path, cfg_path, name = _policy_zip(policy)
    where = str(cfg_path) if name is None else f"pretrained policy {name} ({cfg_path})"
    cfg = load_config(cfg_path)
    _check_exportable(cfg, where)
    env_id = cfg.env_id
    factory, env_kwargs, label = load_policy(name or str(zip_path), env_id, trust)
    env = gym.make(env_id, **design_env_kwargs(env_id, env_kwargs))  # spaces, f_max, scales
    try:
        agent, base = factory(env), None
        if cfg.residual is not None:
            if not isinstance(agent, ResidualPolicy):
                raise RuntimeError(f"{where}: residual {cfg.residual!r} did not load as one")
            try:
                base = linear_base(agent.controller, cfg.residual, agent.scale)
            except ValueError as err:
                raise ValueError(f"{where}: {err}") from None
            agent = agent.policy
        p = policy_net(agent, env.unwrapped)
    finally:
        env.close()
    if base is not None:
        _check_base(base, p, where)
    write_policy_fmu(p, path, label, compiler, base)
    onnx_path = write_policy_onnx(p, Path(onnx), base) if onnx is not None else None
    return path, onnx_path
