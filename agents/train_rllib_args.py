"""Old path of :mod:`agents.training.train_rllib_args`, kept for one version: an import gets that
module itself."""

import sys

from agents.training import train_rllib_args

sys.modules[__name__] = train_rllib_args
