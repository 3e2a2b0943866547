"""Old path of :mod:`agents.evaluation.contacts`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import contacts

sys.modules[__name__] = contacts
