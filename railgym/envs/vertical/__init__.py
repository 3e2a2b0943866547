"""``railgym/VerticalSuspension-v1``: the env (:mod:`.env`), its batch of compiled kernels
(:mod:`.batch`), its FMU batch (:mod:`.fmu_batch`) and its frame (:mod:`.render`).

Import each name from its module.
"""
