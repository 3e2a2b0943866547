"""Agents: classical controllers and stable-baselines3 training (needs the `agents` extra)."""
