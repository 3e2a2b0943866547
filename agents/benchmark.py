"""Old path of :mod:`agents.evaluation.benchmark`, kept for one version: an import gets that
module itself.
``python -m agents.benchmark`` runs it."""

import sys

from agents.evaluation import benchmark

if __name__ == "__main__":
    sys.exit(benchmark.main())
sys.modules[__name__] = benchmark
