"""The controllers room: classical baselines of every env (:mod:`~agents.controllers.classical`,
:mod:`~agents.controllers.lqg`, :mod:`~agents.controllers.preview`,
:mod:`~agents.controllers.semi_active_control`, :mod:`~agents.controllers.crash_baselines`),
their parts (:mod:`~agents.controllers.control_base`, :mod:`~agents.controllers.feedback`), the
wrappers of a trained policy (:mod:`~agents.controllers.residual`,
:mod:`~agents.controllers.action_hold`) and the one table of names and baselines
(:mod:`~agents.controllers.registry`).

Import each name from its module.
"""
