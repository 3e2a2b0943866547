"""The evaluation room: ``railgym evaluate`` (:mod:`~agents.evaluation.evaluate`), its runs
(:mod:`~agents.evaluation.runs`, :mod:`~agents.evaluation.sweeps`), the declared metrics
(:mod:`~agents.evaluation.metrics`), the transfer gap, the benchmark protocol, the crash
reports, the surrogate validation and validity, the element refinement and the speed table."""
