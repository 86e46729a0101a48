# SPDX-License-Identifier: Apache-2.0
"""The service's report (scanprep.v1.Report) as typed, frozen dataclasses: Result.typed_report.
Counts are points, times seconds; a warning's code is its WarningCode name without the
WARNING_CODE_ prefix (e.g. "UNIT_SUSPECT", as STRICT_WARNING_CODES and fail_on name them), its
params the numbers behind it as the service sent them (strings)."""

from __future__ import annotations

import dataclasses
from typing import Optional

from scanprep.v1 import scanprep_pb2 as pb
from scanprep_client.health import Health, health_from_report
from scanprep_client.registration import ScanRegistration, registration_from_report


def _outcome(value: int) -> str:
    """BUDGET_OUTCOME_MET -> "MET" ("NO_BUDGET", "MET", "MISSED"; "" when unspecified)."""
    name = pb.BudgetOutcome.Name(value)
    return "" if value == 0 else name.removeprefix("BUDGET_OUTCOME_")


@dataclasses.dataclass(frozen=True)
class Stage:
    name: str
    points_in: int
    points_out: int
    seconds: float
    parameters: dict[str, float]        # every parameter the stage used; lengths in mm (_mm)
    text_parameters: dict[str, str]     # its choices, e.g. "outliers.method": "nn"
    budget_seconds: float
    budget_outcome: str                 # "NO_BUDGET", "MET" or "MISSED"


@dataclasses.dataclass(frozen=True)
class Warning:
    code: str                  # e.g. "POINTS_INVALID"
    message: str               # for people: the text of Report.warnings
    params: dict[str, str]     # e.g. UNIT_SUSPECT's measured_spacing_mm


@dataclasses.dataclass(frozen=True)
class Budget:
    seconds: float             # the job's budget; 0 when it had none
    outcome: str               # "NO_BUDGET", "MET" or "MISSED"
    processing_seconds: float  # what the stages took

    @property
    def met(self) -> bool:
        return self.outcome != "MISSED"


@dataclasses.dataclass(frozen=True)
class Report:
    job_id: str
    points_received: int
    points_invalid: int        # NaN/Inf coordinates, excluded before processing
    points_processed: int      # received minus invalid
    points_returned: int
    points_coincident_across_scans: int
    stages: tuple[Stage, ...]
    warnings: tuple[Warning, ...]
    budget: Budget
    preset: str
    labels: dict[str, str]
    server_version: str
    estimated_plan_cost: float
    health: Optional[Health]   # None when the "health" stage did not run
    registration: tuple[ScanRegistration, ...]  # empty when the "registration" stage did not run

    def stage(self, name: str) -> Stage:
        """The stage of that name (KeyError when it did not run)."""
        for stage in self.stages:
            if stage.name == name:
                return stage
        raise KeyError(f"stage {name!r} did not run (ran: {[s.name for s in self.stages]})")

    @property
    def warning_codes(self) -> tuple[str, ...]:
        return tuple(w.code for w in self.warnings)


def report_from_pb(report: pb.Report) -> Report:
    """Report as dataclasses. A server older than Warning.code details gets its warnings' text
    with code "" and no params."""
    if report.warning_details:
        warnings = tuple(Warning(code=pb.WarningCode.Name(w.code).removeprefix("WARNING_CODE_"),
                                 message=w.message, params=dict(w.params))
                         for w in report.warning_details)
    else:
        warnings = tuple(Warning(code="", message=text, params={}) for text in report.warnings)
    return Report(
        job_id=report.job_id, points_received=report.points_received,
        points_invalid=report.points_invalid, points_processed=report.points_processed,
        points_returned=report.points_returned,
        points_coincident_across_scans=report.points_coincident_across_scans,
        stages=tuple(Stage(name=s.name, points_in=s.points_in, points_out=s.points_out,
                           seconds=s.seconds, parameters=dict(s.parameters),
                           text_parameters=dict(s.text_parameters),
                           budget_seconds=s.budget_seconds,
                           budget_outcome=_outcome(s.budget_outcome))
                     for s in report.stages),
        warnings=warnings,
        budget=Budget(seconds=report.budget_seconds, outcome=_outcome(report.budget_outcome),
                      processing_seconds=report.processing_seconds),
        preset=report.preset, labels=dict(report.labels), server_version=report.server_version,
        estimated_plan_cost=report.estimated_plan_cost, health=health_from_report(report),
        registration=registration_from_report(report))
