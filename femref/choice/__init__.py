"""Choosing the cheapest impact model expected to meet a tolerance (``femref run --tolerance``).

:mod:`~femref.choice.ladder` lists the models at their resolutions, cheapest first;
:mod:`~femref.choice.estimates` holds the error estimates (asymptotic in ε for the
rigid and quasi-rigid models, Richardson for modal and fem, comparison between runs);
:mod:`~femref.choice.choose` climbs the ladder; :mod:`~femref.choice.output` writes the
choice to the result file and prints it.
"""

from femref.choice.choose import DEFAULT_OUTPUT, ModelChoice, RungEstimate, choose_model, run_rung
from femref.choice.estimates import OUTPUTS
from femref.choice.ladder import Ladder, Rung, check_ladder_budget, model_ladder

__all__ = ["DEFAULT_OUTPUT", "OUTPUTS", "Ladder", "ModelChoice", "Rung", "RungEstimate", "check_ladder_budget", "choose_model", "model_ladder", "run_rung"]
