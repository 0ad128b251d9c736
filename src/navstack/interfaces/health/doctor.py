"""``navstack doctor``: walk the textbook decision tree and name the broken contract.

The lab's tree for "the goal was accepted but the robot does not move" asks, in order:
is ``/cmd_vel`` published? -> is the controller active? -> is TF ok? -> are the velocity
limits zero? -> does the base consume ``/cmd_vel`` (odometry twist follows it)? -> is the
costmap all lethal? -> is the progress checker tripping?  Every question is answered from
measured symptoms (:mod:`.checks` on :class:`~.model.Observations`, live or from a bag)
and the first question whose contract is broken ends the walk with a
:class:`~.model.Diagnosis`.  ``/cmd_vel`` silence is a symptom, not a cause: it is
reported, and named as the broken contract only when no question after it explains it
(the command chain controller -> collision monitor -> base is broken in between).

Questions are asked even while the robot moves: a stale ``map -> odom`` lets a robot
drive for a while on the last transform, which is exactly when it must be caught.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from navstack.interfaces.health.checks import (
    base_consumes_cmd_vel,
    cmd_vel_published,
    controller_active,
    costmaps_not_lethal,
    progress,
    robot_motion,
    tf_chain,
    velocity_limits,
)
from navstack.interfaces.health.model import (
    CheckResult,
    Diagnosis,
    HealthParams,
    Observations,
)

HEALTHY = "none"


@dataclass(frozen=True)
class Step:
    """One question of the walk: its contract, the answer and the evidence behind it.

    ``broken``: the contract is violated; ``symptom``: the question observes an effect
    (motion, command flow) rather than a cause."""

    question: str
    contract: str
    answer: str
    evidence: str
    broken: bool
    symptom: bool = False
    fix: str = ""


@dataclass(frozen=True)
class DoctorReport:
    """The walk and its verdict."""

    source: str
    steps: tuple[Step, ...]
    diagnosis: Diagnosis

    @property
    def healthy(self) -> bool:
        return self.diagnosis.contract == HEALTHY

    def lines(self) -> list[str]:
        """The walk, one question per line with answer and evidence, then the verdict."""
        out = [f"doctor on {self.source}:"]
        for i, s in enumerate(self.steps, 1):
            mark = "BROKEN" if s.broken and not s.symptom else s.answer
            out.append(f"  {i}. {s.question} {mark} -- {s.evidence}")
        d = self.diagnosis
        if self.healthy:
            out.append(f"diagnosis: no broken contract ({d.evidence})")
        else:
            out.append(f"diagnosis: broken contract '{d.contract}': {d.evidence}")
            out.append(f"fix: {d.fix}")
        return out


def _step(question: str, result: CheckResult, yes_when_ok: bool = True,
          symptom: bool = False, contract: str | None = None) -> Step:
    judged = not result.detail.startswith("not judged")
    answer = "n/a" if not judged else "yes" if result.ok == yes_when_ok else "no"
    return Step(question, contract or result.name, answer, result.detail, not result.ok,
                symptom, result.fix)


def _costmap_result(obs: Observations, params: HealthParams) -> CheckResult:
    results = costmaps_not_lethal(obs, params)
    if not results:
        return CheckResult("costmap_not_lethal", True, "not judged: no costmap observed")
    bad = [r for r in results if not r.ok]
    detail = "; ".join(f"{r.name.split(':', 1)[-1]}: {r.detail}" for r in (bad or results))
    return CheckResult("costmap_not_lethal", not bad, detail, bad[0].fix if bad else "")


def _goal_step(obs: Observations) -> Step:
    accepted = [g for g in obs.goals if g.status != "REJECTED"]
    if accepted:
        g = accepted[0]
        ended = "" if g.end is None else f", ended {g.status} at t={g.end:.2f} s"
        why = f" ({g.reason})" if g.reason and g.status != "SUCCEEDED" else ""
        return Step("Was the goal accepted?", "goal_accepted", "yes",
                    f"accepted at t={g.start:.2f} s{ended}{why}", False)
    rejected = [g for g in obs.goals if g.status == "REJECTED"]
    evidence = (f"rejected: {rejected[0].reason}" if rejected
                else "no navigation goal was observed")
    return Step("Was the goal accepted?", "goal_accepted", "no", evidence, True, False,
                "check that bt_navigator is ACTIVE and the goal is finite and in a frame TF "
                "knows (the rejection reason says which)")


def _motion_step(obs: Observations, params: HealthParams) -> Step:
    dist, span = robot_motion(obs)
    moving = dist > params.required_movement_radius
    return Step("Does the robot move?", "motion", "yes" if moving else "no",
                f"moved up to {dist:.2f} m from its start (odometry) in {span:.1f} s of "
                f"active goal", not moving,
                symptom=True)


Question = Callable[[Observations, HealthParams], Step]

QUESTIONS: tuple[Question, ...] = (
    lambda o, p: _step("Is /cmd_vel published?", cmd_vel_published(o, p, since=o.start),
                       symptom=True),
    lambda o, p: _step("Is the controller server active?", controller_active(o, p)),
    lambda o, p: _step("Is TF ok (map -> odom -> base_link fresh)?", tf_chain(o, p)),
    lambda o, p: _step("Are the velocity limits zero?", velocity_limits(o, p),
                       yes_when_ok=False),
    lambda o, p: _step("Does the base consume /cmd_vel (odom twist follows it)?",
                       base_consumes_cmd_vel(o, p)),
    lambda o, p: _step("Is the costmap all lethal?", _costmap_result(o, p), yes_when_ok=False),
    lambda o, p: _step("Is the progress checker tripping?", progress(o, p),
                       yes_when_ok=False),
)
"""The tree's questions after "was the goal accepted / does the robot move", in order."""


def diagnose(obs: Observations, params: HealthParams | None = None) -> DoctorReport:
    """Walk the decision tree on ``obs``; the first broken contract is the diagnosis."""
    params = params or HealthParams()
    steps = [_goal_step(obs)]
    if steps[0].broken:
        s = steps[0]
        return DoctorReport(obs.source, tuple(steps), Diagnosis(s.contract, s.evidence, s.fix))
    steps.append(_motion_step(obs, params))
    for question in QUESTIONS:
        step = question(obs, params)
        steps.append(step)
        if step.broken and not step.symptom:
            return DoctorReport(obs.source, tuple(steps),
                                Diagnosis(step.contract, step.evidence, step.fix))
    silent = next((s for s in steps if s.contract == "cmd_vel_published" and s.broken), None)
    if silent is not None:
        return DoctorReport(obs.source, tuple(steps), Diagnosis(
            silent.contract, silent.evidence + "; controller, TF and costmaps are fine",
            "follow the command chain: controller_server publishes cmd_vel_topic "
            "(/cmd_vel_nav), the collision monitor republishes it on /cmd_vel -- check "
            "both topic names and that the collision monitor is ACTIVE"))
    motion = steps[1]
    return DoctorReport(obs.source, tuple(steps),
                        Diagnosis(HEALTHY, f"every contract holds; {motion.evidence}",
                                  "nothing to fix"))
