"""Health checks, live monitoring, fault injection and ``navstack doctor``.

The textbook lab's observability contract: every failure of the navigation pipeline has
measurable symptoms.  :class:`HealthMonitor` measures them on a running stack
(``HealthMonitor(stack).report() -> list[CheckResult]``), :func:`observations_from_bag`
on a recording, :func:`diagnose` walks the decision tree over either and names the
broken contract, and :func:`inject_fault` breaks one contract of a simulated stack on
purpose.  See ``docs/health.md``.
"""

from navstack.interfaces.health.bag import HEALTH_TOPICS, observations_from_bag
from navstack.interfaces.health.checks import all_checks
from navstack.interfaces.health.doctor import DoctorReport, Step, diagnose
from navstack.interfaces.health.faults import FAULTS, InjectedFault, inject_fault
from navstack.interfaces.health.model import (
    CheckResult,
    Diagnosis,
    HealthError,
    HealthParams,
    Observations,
)
from navstack.interfaces.health.monitor import HealthMonitor
from navstack.interfaces.health.session import (
    HealthSession,
    build_stack,
    diagnose_bag,
    pick_goal,
)

__all__ = [
    "FAULTS", "HEALTH_TOPICS", "CheckResult", "Diagnosis", "DoctorReport", "HealthError",
    "HealthMonitor", "HealthParams", "HealthSession", "InjectedFault", "Observations", "Step",
    "all_checks", "build_stack", "diagnose", "diagnose_bag", "inject_fault",
    "observations_from_bag", "pick_goal",
]
