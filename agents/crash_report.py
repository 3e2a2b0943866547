"""Old path of :mod:`agents.evaluation.crash_report`, kept for one version: an import gets that
module itself.
``python -m agents.crash_report`` runs it."""

import sys

from agents.evaluation import crash_report

if __name__ == "__main__":
    sys.exit(crash_report.main())
sys.modules[__name__] = crash_report
