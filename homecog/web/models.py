"""The HTTP contract: a pydantic model for every input and output.

The context is made per home (:class:`HomeModels`): an object with one property per feature
and device — an enum of the values of a categorical feature, a number within the bins of a
numeric one, ``HH:MM`` (or decimal hours) for the clock, ``"on"``/``"off"`` for a device — so
that the OpenAPI schema says exactly what the server takes, and the server takes exactly what it
says. The same context comes back from ``GET /api/context``, so an answer can be sent again.

>>> from homecog.home import load_home
>>> models = HomeModels.of(load_home("paper"))
>>> schema = models.cognize_in.model_json_schema()["$defs"]["Context"]
>>> schema["properties"]["location"]["enum"]
['table', 'sofa', 'bed', 'dining_table']
>>> {k: v for k, v in schema["properties"]["illumination"].items() if k != "description"}
{'minimum': 0.0, 'title': 'Illumination', 'type': 'number'}
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal, Self

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, Strict, create_model, model_validator
from pydantic_core import PydanticCustomError
from typing_extensions import TypedDict

from homecog.home.model import Feature, Home
from homecog.names import MAX_NAME, USER_PATTERN, USER_RULE, user_name_problem
from homecog.robot.plans import MAX_PLAN_SERVICES

# Decimal hours or HH:MM[:SS] from 00:00 to 24:00, ASCII digits. Every string it matches is
# accepted by the home's own parser (homecog.home.model.parse_clock) with the same meaning;
# tests/test_contract.py checks both directions. Python's `re` semantics (a final newline
# before `$`), as the fuzzer and the server both use them.
CLOCK_PATTERN = (
    r"^(?:(?:[01]?[0-9]|2[0-3]):[0-5][0-9](?::[0-5][0-9])?|24:00(?::00)?"
    r"|(?:[01]?[0-9]|2[0-3])(?:\.[0-9]+)?|24(?:\.0+)?)$"
)
STRICT = ConfigDict(extra="forbid", regex_engine="python-re")


def _user_name(value: str) -> str:
    problem = user_name_problem(value)
    if problem is not None:
        raise PydanticCustomError("user_name", problem)
    return value


#: A user name (:mod:`homecog.names`): the rule checked with its own message, the schema
#: stating it as a pattern.
User = Annotated[
    str,
    AfterValidator(_user_name),
    Field(
        description="Whose services these are: corrections are per user. " + USER_RULE + ".",
        examples=["default"],
        json_schema_extra={"minLength": 1, "maxLength": MAX_NAME, "pattern": USER_PATTERN},
    ),
]
State = Literal["on", "off"]


class ErrorOut(BaseModel):
    """Every error answer: one message naming what is wrong."""

    detail: str = Field(description="What is wrong, in one line.", examples=["missing radio"])


# -- answers -----------------------------------------------------------------------------------
class EvidenceOut(BaseModel):
    agreed: int = Field(
        description="The user's corrections in the answering cell that agree with the answer."
    )
    disagreed: int = Field(description="Those that do not.")
    corrections: list[int] = Field(
        description="The user's numbers (1: their first) of the latest that agree."
    )


class ExplanationOut(BaseModel):
    service: str
    category: str = Field(description="The service's category (the tree's middle level).")
    priority: float = Field(description="Higher first: the order the services are carried out in.")
    cluster: int = Field(description="The experience cluster that answered.")
    user: str | None = Field(description="Whose correction made the cluster; null: common knowledge.")
    conditions: dict[str, str] = Field(description="What the cluster matched, per feature or device.")
    evidence: EvidenceOut | None = Field(
        None,
        description="A user's answer: the corrections that answered and how many agreed; null otherwise.",
    )


class CognizeOut(BaseModel):
    services: list[str] = Field(description="In priority order.")
    unknown: bool = Field(description="True when no experience answers the context.")
    explanations: list[ExplanationOut]
    probabilities: dict[str, float] = Field(
        default_factory=dict,
        description="Per service proposed: the probability (0 to 1) that the user wants it now, "
        "calibrated on the household's own corrections.",
    )


class StoredCorrection(BaseModel):
    kind: str = Field(description="`explicit` (a user said it), `observed` (a switch by hand) or `undo`.")
    want: list[str] = Field(description="The services wanted.")
    concerns: list[str] | None = Field(description="The services it speaks of; null: every service.")


class CorrectionOut(BaseModel):
    added: list[str] = Field(description="Wanted services the robot had not proposed.")
    rejected: list[str] = Field(description="Proposed services the user did not want.")
    experiences: int = Field(description="Experiences in the log now.")
    user: str
    number: int = Field(description="The user's corrections stored, this one included.")
    stored: StoredCorrection = Field(description="What was stored, whatever the robot had proposed.")
    says: str = Field(description="What was stored, in words.")


class ActionNode(BaseModel):
    action: list[str] = Field(description="[name, args...]")
    index: int = Field(description="Its position in the plan, from 1.")


class TaskNode(BaseModel):
    task: list[str] = Field(description="[name, args...]")
    method: str | None = Field(description="The method that decomposed it.")
    children: list[TaskNode | ActionNode]


class TimelineRow(BaseModel):
    index: int
    action: list[str]
    start: float = Field(description="Seconds from the start of the plan.")
    end: float
    distance_m: float


class SimulationOut(BaseModel):
    seconds: float
    distance_m: float
    timeline: list[TimelineRow]
    devices: dict[str, State] = Field(description="The devices when the plan is done.")
    trajectory: list[list[float]] = Field(description="At most 400 rows [t, x, y]: seconds, metres.")


class PlanOut(BaseModel):
    actions: list[list[str]] = Field(description="The robot's atomic actions in order: [name, args...].")
    tree: list[TaskNode | ActionNode] = Field(description="The decomposition tree, a root per service.")
    simulation: SimulationOut


class HistoryCorrectionOut(BaseModel):
    id: int = Field(description="Its place in the log (give it as `before` for the older ones).")
    at: float = Field(description="When it was stored: seconds since 1970 (UTC).")
    user: str
    want: list[str] = Field(description="What the user wanted.")
    predicted: list[str] = Field(description="What the robot had proposed.")
    agreed: bool = Field(description="Whether the robot had proposed just that.")
    kind: Literal["explicit", "observed", "undo"] = Field(
        "explicit",
        description="Told (the HMI, the API, the CLI), seen (a person switched by hand), or an undo "
        "of the robot's switch.",
    )
    weight: int = Field(1, description="How many corrections' worth it counts.")
    concerns: list[str] | None = Field(
        None, description="The services it speaks of (null: all, the whole set wanted)."
    )


class AgreementOut(BaseModel):
    n: int = Field(description="The correction's number, from 1.")
    user: str
    agreed: bool
    rate: float = Field(description="The share of corrections so far the robot already agreed with.")


class HistoryOut(BaseModel):
    total: int = Field(description="Corrections in the experience log (of the user, if asked).")
    corrections: list[HistoryCorrectionOut] = Field(description="The latest, oldest first.")
    before: int | None = Field(
        description="Give it as `before` for the page of older corrections; null: there are none."
    )
    agreement: list[AgreementOut] = Field(description="The running agreement over those corrections.")


# -- a correction: the whole set wanted, or a change of some services ---------------------------
#: The validation errors a correction's own rules raise; their message is the whole answer.
CORRECTION_ERRORS = ("correction_form", "correction_change_empty")  # their message says it all
WHOLE_OR_CHANGE = "want (the whole set wanted) or change (some services)"


class CorrectionForm(BaseModel):
    """A correction gives ``want`` (every service wanted there; the others are not) or ``change``
    (some services, each ``"add"`` or ``"reject"``; every other service keeps what it had), never
    both: a ``oneOf`` of the two in the schema, and :meth:`one_form` here."""

    model_config = ConfigDict(
        **STRICT, json_schema_extra={"oneOf": [{"required": ["want"]}, {"required": ["change"]}]}
    )

    @model_validator(mode="after")
    def one_form(self) -> Self:
        """Exactly one of ``want`` and ``change`` given."""
        given = {"want", "change"} & self.model_fields_set
        if len(given) != 1:
            message = f"give {WHOLE_OR_CHANGE}, not both" if given else f"missing {WHOLE_OR_CHANGE}"
            raise PydanticCustomError("correction_form", message)
        return self


def _names_a_service(change: dict[str, str]) -> dict[str, str]:
    if not change:
        raise PydanticCustomError(
            "correction_change_empty", 'change names no service; give some, each "add" or "reject"'
        )
    return change


def _change_type(home: Home) -> Any:
    """``{service: "add" | "reject"}`` for some of the home's services: an object cannot name a
    service twice, so no service is both added and rejected."""
    verdict = Annotated[
        Literal["add", "reject"],
        Field(description='"add": wanted here too; "reject": not wanted here.'),
    ]
    change: Any = TypedDict("CorrectionChange", dict.fromkeys(home.service_names, verdict), total=False)  # type: ignore[misc]
    change.__pydantic_config__ = ConfigDict(**STRICT, json_schema_extra={"minProperties": 1})
    return Annotated[change, AfterValidator(_names_a_service)]


# -- the context of one home --------------------------------------------------------------------
@dataclass(frozen=True)
class HomeModels:
    """The models whose shape depends on the home: the context and what carries it."""

    home: Home
    context: Any  # a TypedDict: every feature and device
    context_change: Any  # a TypedDict: some features or devices
    service: Any  # Literal of the service names
    cognize_in: type[BaseModel]
    correction_in: type[BaseModel]
    plan_in: type[BaseModel]
    context_in: type[BaseModel]
    answer_in: type[BaseModel]

    @classmethod
    def of(cls, home: Home) -> HomeModels:
        fields = {f.name: _feature_type(f) for f in home.features}
        fields |= {
            d.name: Annotated[State, Field(description=f"Device{f' ({d.room})' if d.room else ''}.")]
            for d in home.devices
        }
        context: Any = TypedDict("Context", fields)  # type: ignore[misc]
        context.__pydantic_config__ = STRICT
        change: Any = TypedDict("ContextChange", fields, total=False)  # type: ignore[misc]
        change.__pydantic_config__ = STRICT
        service: Any = Literal[tuple(home.service_names)]  # type: ignore[valid-type]
        in_context = Field(description="Every feature and device of the home.")
        default_user = (User, home.household.default_user)  # whom a body naming nobody speaks for
        cognize_in = create_model(
            "CognizeIn", __config__=STRICT, context=(context, in_context), user=default_user
        )
        correction_in = create_model(
            "CorrectionIn",
            __base__=CorrectionForm,
            __doc__="The services the user wants in the context: `want`, the whole set (every other "
            'service is not wanted), or `change`, some services each "add" or "reject" (every other '
            "service keeps what it had); one of the two, never both.",
            context=(context, in_context),
            want=(
                list[service],
                Field(
                    default_factory=list,
                    max_length=200,
                    description="The whole set of services wanted (empty: none); the others are not.",
                ),
            ),
            change=(
                _change_type(home),
                Field(
                    default_factory=dict,
                    description='Instead of want: some services, each "add" or "reject"; every '
                    "other service keeps what it had.",
                ),
            ),
            user=default_user,
        )
        plan_in = create_model(
            "PlanIn",
            __config__=STRICT,
            services=(
                list[service],
                Field(min_length=1, max_length=MAX_PLAN_SERVICES, description="In this order."),
            ),
            context=(context | None, Field(None, description="Where; the devices start as it says.")),
        )
        context_in = create_model(
            "ContextIn",
            __config__=STRICT,
            values=(change, Field(description="Features or devices to change.")),
        )
        answer_in = create_model(
            "AnswerIn",
            __config__=STRICT,
            __doc__="A user's yes or no to one of the robot's pending proposals in the context.",
            context=(context, Field(description="The context the robot proposed the service in.")),
            service=(service, Field(description="One service the robot proposed to the user there.")),
            answer=(
                Literal["yes", "no"],
                Field(description='"yes": wanted (learned as an addition); "no": not wanted here.'),
            ),
            user=default_user,
        )
        return cls(home, context, change, service, cognize_in, correction_in, plan_in, context_in, answer_in)


def _feature_type(f: Feature) -> Any:
    bins = ", ".join(f"{v} {f.describe_bin(k)}" for k, v in enumerate(f.values))
    if f.kind == "categorical":
        return Annotated[Literal[tuple(f.values)], Field(description="Categorical.")]  # type: ignore[valid-type]
    if f.kind == "clock":
        hours = Annotated[float, Strict(), Field(ge=0, le=24, allow_inf_nan=False)]
        text = Annotated[str, Field(pattern=CLOCK_PATTERN)]
        return Annotated[text | hours, Field(description=f'"HH:MM" or decimal hours; bins {bins}')]
    assert f.bins is not None  # numeric: bins neither overlap nor leave a gap
    low, high = min(b[0] for b in f.bins), max(b[1] for b in f.bins)
    bounds: dict[str, float] = {}
    if not math.isinf(low):
        bounds["ge"] = low
    if not math.isinf(high):
        bounds["lt"] = high
    return Annotated[
        float, Strict(), Field(allow_inf_nan=False, description=f"A number; bins {bins}", **bounds)
    ]
