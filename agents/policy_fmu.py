"""A trained policy as a standalone FMI 2.0 co-simulation FMU in C, and as ONNX.

``railgym export-policy POLICY -o controller.fmu [--onnx controller.onnx]``: the SB3 MLP
policy (PPO or SAC, as :mod:`agents.train` writes them) is loaded as weights only, after the
manifest check (:func:`agents.policies.load_policy`); its deterministic action is written out
as plain C (``agents/c/policy_element.h`` on the generic FMI element of
``surrogates/fmi/c/element.c``) with no Python in the host:

* inputs: the env's observation channels in SI, named after ``obs_names``, in its order;
* inside: the env's observation scaling (``obs / obs_scale``, rounded to float32 as the env
  does), the MLP (float32 weights, double sums), SAC's ``tanh`` squashing, the clipping of
  the action space, and ``force = action · f_max``;
* outputs: the actuator forces in N (``actuator_force``; ``actuator_force_front``,
  ``actuator_force_rear`` for ``VerticalVehicle-v1``).

The ONNX graph computes the same from a ``(batch, n_obs)`` double input ``observation`` to
a ``(batch, n_act)`` float output ``actuator_force`` (needs the ``onnx`` extra).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

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


def _data_header(p: PolicyNet, guid: str, names: list[str]) -> str:
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
            "/* generated by agents.policy_fmu: one trained policy */",
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


def write_policy_fmu(p: PolicyNet, path: Path, label: str, compiler: str | None = None) -> Path:
    """Write the FMU of :class:`PolicyNet` ``p`` to ``path`` (co-simulation)."""
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
    text = json.dumps(doc, sort_keys=True)
    guid = guid_of(text)
    ident = identifier(path, None)
    names = list(p.obs_names)
    inputs = [
        Variable(n, unit_of(n), f"observation channel {n} (SI; the env's obs × {s!r})")
        for n, s in zip(names, p.obs_scale, strict=True)
    ]
    outputs = [
        Variable(n, "N", f"actuator force {k + 1} = action × f_max ({p.f_max!r} N)")
        for k, n in enumerate(force_names(n_act))
    ]
    xml = model_description(
        model_identifier=ident,
        guid=guid,
        description=f"railgym controller: policy {label}, deterministic action as force",
        inputs=inputs,
        outputs=outputs,
        starts=[0.0] * len(names),
        kinds=("cs",),
        source_files=("element.c",),
    )
    header = (resources.files("agents") / "c" / "policy_element.h").read_text()
    sources = {
        "element_data.h": _data_header(p, guid, names),
        "policy_element.h": header,
        "element.c": template("element.c"),
    }
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


def write_policy_onnx(p: PolicyNet, path: Path) -> Path:
    """Write the ONNX graph of :class:`PolicyNet` ``p`` (needs the ``onnx`` extra)."""
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
        helper.make_node(
            "Mul", ["action", const("f_max", np.full(1, p.f_max, f32))], ["actuator_force"]
        ),
    ]
    graph = helper.make_graph(
        nodes,
        "railgym_policy",
        [helper.make_tensor_value_info("observation", TensorProto.DOUBLE, ["batch", n_obs])],
        [helper.make_tensor_value_info("actuator_force", TensorProto.FLOAT, ["batch", n_act])],
        inits,
        doc_string="observation: the env's channels in SI (" + ", ".join(p.obs_names) + "); "
        "actuator_force: N",
    )
    model = helper.make_model(
        graph, producer_name="railgym", opset_imports=[helper.make_opsetid("", 17)]
    )
    model.ir_version = 8
    onnx.checker.check_model(model)
    path.write_bytes(model.SerializeToString())
    return path


def export_policy(
    policy: str | Path,
    path: str | Path,
    onnx: str | Path | None = None,
    *,
    trust: bool = False,
    overwrite: bool = False,
    compiler: str | None = None,
) -> tuple[Path, Path | None]:
    """Write the policy zip ``policy`` (with ``config.yaml`` and ``manifest.json`` beside
    it, as :mod:`agents.train` writes them) as an FMU at ``path`` and optionally as ONNX.

    The env and its settings (observation, ``f_max``) are the config's; ``trust`` loads a
    zip the manifest does not list (see :func:`agents.policies.load_policy`).
    """
    from agents.policies import load_policy
    from agents.train_config import load_config

    policy, path = Path(policy), Path(path)
    outs = [path] + ([Path(onnx)] if onnx is not None else [])
    for out, suffix in zip(outs, (".fmu", ".onnx"), strict=False):
        if out.suffix != suffix:
            raise ValueError(f"output {str(out)!r} must end in {suffix}")
        if out.exists() and not overwrite:
            raise FileExistsError(f"{out} exists; pass --overwrite to replace it")
    cfg_path = policy.parent / "config.yaml"
    if policy.suffix != ".zip" or not policy.is_file() or not cfg_path.is_file():
        raise ValueError(
            f"policy must be a stable-baselines3 .zip with the config.yaml of its training "
            f"beside it, got {str(policy)!r}"
        )
    cfg = load_config(cfg_path)
    if cfg.action_hold > 1:
        raise ValueError(
            f"{cfg_path}: action_hold is {cfg.action_hold}, but the FMU decides at every step"
        )
    if cfg.residual is not None:
        raise ValueError(
            f"{cfg_path}: residual is {cfg.residual!r}, but the FMU holds the network only "
            "(not the controller its action is added to)"
        )
    env_id = cfg.env_id
    factory, env_kwargs, label = load_policy(str(policy), env_id, trust)
    env = gym.make(env_id, **env_kwargs)
    try:
        p = policy_net(factory(env), env.unwrapped)
    finally:
        env.close()
    write_policy_fmu(p, path, label, compiler)
    onnx_path = write_policy_onnx(p, Path(onnx)) if onnx is not None else None
    return path, onnx_path
