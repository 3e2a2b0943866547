"""Old path of :mod:`agents.training.train_config`, kept for one version: an import gets that
module itself."""

import sys

from agents.training import train_config

sys.modules[__name__] = train_config
