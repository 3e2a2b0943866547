"""FMI 2.0 in both directions: FMUs as the reference of an env (``backend="fmu"``), and FMUs of
railgym's reference models and trained controllers (see ``docs/fmi.md``)."""
