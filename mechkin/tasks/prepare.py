"""What validation computes that the run needs, computed once and handed on (issue 23).

:func:`prepare` loads the scenario's mechanism, validates the scenario against it
(:func:`mechkin.tasks.validate.validate_scenario`, as ``mechkin check`` does) and keeps in a
:class:`Prepared` record what the validation had to compute anyway: the mechanism itself, the
recognised closed form of an ik scenario (recognising it reads the mechanism's geometry from
its assembled home configuration: a loop closure and forward kinematics) and the biped legs read
from the mechanism. :func:`mechkin.tasks.run` hands the record to the task's ``run``, so a
scenario walks down the house once; a task run on its own (``prepared=None``) computes them
itself.

Imports: model, solvers.closed_form (lazily), tasks.validate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: Prepared.closed_form before anything was recognised.
UNCHECKED = "unchecked"


@dataclass
class Prepared:
    """The facts validation established about a scenario's mechanism.

    Attributes
    ----------
    mechanism : Mechanism or None
        The loaded mechanism (None for a task that needs none).
    closed_form : str or None
        ik: the closed form that solves the mechanism (declared and checked, or recognised),
        None when none fits, :data:`UNCHECKED` when nobody asked.
    closed_form_error : str or None
        ik: why a declared closed form does not fit (ClosedFormMismatch message), else None.
    biped_model : BipedModel or None
        ik with ``biped:``: the legs read from the mechanism
        (:func:`mechkin.solvers.biped.sequence.geometry_from_mechanism`).
    """

    mechanism: Any = None
    closed_form: str | None = UNCHECKED
    closed_form_error: str | None = None
    biped_model: Any = None

    def recognise_closed_form(self) -> str | None:
        """The closed form of the mechanism (recognised once, then remembered); raises
        ClosedFormMismatch when a declared one does not fit."""
        from mechkin.solvers.closed_form.recognise import (
            ClosedFormMismatch,
            recognise_closed_form,
        )

        if self.closed_form == UNCHECKED:
            try:
                self.closed_form = recognise_closed_form(self.mechanism)
            except ClosedFormMismatch as exc:
                self.closed_form, self.closed_form_error = None, str(exc)
        if self.closed_form_error is not None:
            raise ClosedFormMismatch(self.closed_form_error)
        return self.closed_form


def prepare(scenario: Any) -> Prepared:
    """Load the mechanism of ``scenario`` and validate the scenario against it (ConfigError
    listing every problem); return what the run needs."""
    from mechkin.tasks.validate import validate_scenario

    prep = Prepared()
    if scenario.mechanism_path is not None:
        from mechkin.model import load_mechanism

        prep.mechanism = load_mechanism(scenario.mechanism_path)
    validate_scenario(scenario, prep.mechanism, prepared=prep)
    return prep
