"""The figure registry: which figures a results folder supports.

Each kind looks at the data and returns the figure files it will draw (``FigurePlan``) or a
one-line reason to skip. Kinds, in the order ``plot`` draws them:

========================================  ==================================================
kind                                      drawn when
========================================  ==================================================
slowdown vs threshold                     threshold_pct takes >= 2 values, rest fixed (RT node)
slowdown vs sampling period               sampling_period_us takes >= 2 values (RT node)
slowdown vs regulation period             regulation_period_us takes >= 2 values at a fixed
                                          sampling period (RT node)
RT x nRT grid                             an RT workload runs against >= 2 nRT workloads
RT vs nRT trade-off                       a workload pair has >= 2 regulation settings
mechanism comparison                      >= 2 (policy, sampling) combinations co-run
activation delay vs sampling period       activation_delay samples exist (one sampling
                                          period: a box per series)
PMC callback duration vs sampling period  pmc_callback samples exist (idem)
sampling overhead vs sampling period      nRT-alone points at >= 2 sampling periods
isolation figures (Table 1)               >= 2 workloads with isolation figures, no co-run
========================================  ==================================================

Every slowdown figure also draws the unregulated co-run (``rt_/nrt_unregulated_slowdown``) and
the RT target where one is given (``rosguard plot --rt-slowdown-max``, tune.json): see
``analysis.figures.reference``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from analysis.figures import distributions, grid, isolation, lines, mechanisms, tradeoff
from analysis.figures.base import FigurePlan, Skipped


@dataclass(frozen=True)
class Kind:
    """A registered figure kind: a name and a planner (Results -> [FigurePlan] | reason)."""

    name: str
    plan: Callable


REGISTRY = (
    Kind(lines.SLOWDOWN_VS_THRESHOLD.name, lines.SLOWDOWN_VS_THRESHOLD.plan),
    Kind(lines.SLOWDOWN_VS_SAMPLING.name, lines.SLOWDOWN_VS_SAMPLING.plan),
    Kind(lines.SLOWDOWN_VS_REGULATION.name, lines.SLOWDOWN_VS_REGULATION.plan),
    Kind(grid.KIND, grid.plan),
    Kind(tradeoff.KIND, tradeoff.plan),
    Kind(mechanisms.KIND, mechanisms.plan),
    Kind(distributions.ACTIVATION_DELAY.name, distributions.ACTIVATION_DELAY.plan),
    Kind(distributions.PMC_CALLBACK.name, distributions.PMC_CALLBACK.plan),
    Kind(lines.SAMPLING_OVERHEAD.name, lines.SAMPLING_OVERHEAD.plan),
    Kind(isolation.KIND, isolation.plan),
)


def plan_figures(results):
    """([FigurePlan], [Skipped]) for a loaded results folder, in registry order."""
    plans, skipped = [], []
    for kind in REGISTRY:
        outcome = kind.plan(results)
        if isinstance(outcome, str):
            skipped.append(Skipped(kind.name, outcome))
        else:
            plans.extend(outcome)
    return plans, skipped


__all__ = ["FigurePlan", "Skipped", "REGISTRY", "plan_figures"]
