"""Policies a user picks by name; each decides from belief only (never from ``world``).

Built-ins: ``failure_aware`` (the paper's Algorithm 1), ``vanilla`` and ``sog`` (baselines),
``callable`` (a learned policy: any function from a robot's view to its velocity) and ``onnx``
(a trained team saved as ONNX, ``onnx:team.onnx``).
Other packages add policies through the entry-point group ``resilient_tracking.policies`` or a
scenario names a class directly as ``package.module:Class`` (:mod:`resilient_tracking.registry`).
"""

from __future__ import annotations

from resilient_tracking.policies.base import POLICIES, Decision, NoParams, Policy, register_policy
from resilient_tracking.policies.failure_aware import FailureAwarePolicy
from resilient_tracking.policies.learned import CallablePolicy
from resilient_tracking.policies.onnx_policy import OnnxPolicy
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.policies.sog import SogPolicy
from resilient_tracking.policies.vanilla import VanillaPolicy

__all__ = [
    "POLICIES",
    "CallablePolicy",
    "Decision",
    "FailureAwarePolicy",
    "NoParams",
    "OnnxPolicy",
    "PlanningPolicy",
    "Policy",
    "SogPolicy",
    "VanillaPolicy",
    "register_policy",
]
