"""``railgym/TrainCrash-v1``: the env (:mod:`.env`), its declared arguments (:mod:`.params`),
its batch (:mod:`.batch`) with the compiled step (:mod:`.step`) and the buffer layout
(:mod:`.layout`), and its frame (:mod:`.render`).

Import each name from its module.
"""
