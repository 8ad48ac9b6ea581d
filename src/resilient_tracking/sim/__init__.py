"""Simulation: the episode loop joining world and team, metrics, and the run files it writes."""
