"""Belief: what robots know — target estimates, zone knowledge, leagues. Never imports ``world``."""
