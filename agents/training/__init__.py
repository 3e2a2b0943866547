"""The training room: stable-baselines3 (:mod:`~agents.training.train`) and RLlib
(:mod:`~agents.training.train_rllib`) training from configs (:mod:`~agents.training.train_config`),
the run folder (:mod:`~agents.training.run_files`) and the operating envelope of an episode
(:mod:`~agents.training.envelope`)."""
