"""Experiments: running policies over seeds and summarising the outcome."""
