"""Seeding and partial resets shared by the native vector envs."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils import seeding

from railgym import _checks as val


def reset_options(options: Any) -> dict[str, Any]:
    """A copy of ``reset(options=...)``: ``None`` or a mapping of option names (strings);
    anything else is a ``FieldTypeError`` naming ``options``."""
    if options is None:
        return {}
    options = dict(val.mapping(options, "options"))
    for key in options:
        if not isinstance(key, str):
            raise val.FieldTypeError("options", f"keys must be option names, got {key!r}")
    return options


def reset_plan(
    n: int,
    seed: int | list[int | None] | None,
    options: dict[str, Any] | None,
    rngs: list[np.random.Generator | None],
) -> tuple[np.ndarray, list[np.random.Generator | None], dict[str, Any]]:
    """Which sub-envs to reset and with which generators.

    Sub-env ``i`` is seeded with ``seed + i`` (an int ``seed``) or ``seed[i]`` (a list);
    ``options["reset_mask"]`` (bool array (n,)) restricts the reset to those sub-envs
    (gymnasium's partial reset), where a sub-env without a seed keeps its generator.

    Returns ``(mask, rngs, options without reset_mask)``.
    """
    options = reset_options(options)
    mask = options.pop("reset_mask", None)
    if mask is None:
        mask = np.ones(n, np.bool_)
    elif not (
        isinstance(mask, np.ndarray)
        and mask.dtype == np.bool_
        and mask.shape == (n,)
        and mask.any()
    ):
        raise ValueError(f"options['reset_mask'] must be a bool array ({n},) with a True value")
    if seed is None or isinstance(seed, (int, np.integer)):
        seeds = [None if seed is None else int(seed) + i for i in range(n)]
    elif isinstance(seed, list | tuple) and len(seed) == n:
        seeds = list(seed)
    else:
        raise ValueError(f"seed must be None, an int or a list of {n} seeds, got {seed!r}")
    rngs = list(rngs) if len(rngs) == n else [None] * n
    for i in np.flatnonzero(mask):
        if seeds[i] is not None or mask.all() or rngs[i] is None:
            rngs[i] = seeding.np_random(seeds[i])[0]
    return mask, rngs, options
