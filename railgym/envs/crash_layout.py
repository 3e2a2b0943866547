"""Deprecated path of :mod:`railgym.envs.crash.layout`; kept for one version."""

from railgym.envs.crash.layout import (
    CLEARED,
    COLUMNS,
    ENV_FIELDS,
    EPISODE,
    INFO_FIELDS,
    REWARD_TERMS,
    Array,
    Episode,
    InfoColumns,
    InfoKey,
    buffer_views,
    episode_shapes,
    info_layout,
    named_rebuild,
    new_episode_arrays,
    row_clearer,
)

__all__ = [
    "Array",
    "CLEARED",
    "COLUMNS",
    "ENV_FIELDS",
    "EPISODE",
    "Episode",
    "INFO_FIELDS",
    "InfoColumns",
    "InfoKey",
    "REWARD_TERMS",
    "buffer_views",
    "episode_shapes",
    "info_layout",
    "named_rebuild",
    "new_episode_arrays",
    "row_clearer",
]
