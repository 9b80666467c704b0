"""ClassifySubstance (StirLearn): stir the dipped stick along a predefined movement, then tell
the substance from what the fingers felt, with a model trained by `fvtree train stir`."""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from behaviours.skill_kit import keys
from behaviours.skill_kit.base import Param, ProgramSkill
from behaviours.skill_kit.model_files import UsesModel
from behaviours.skill_kit.registry import register
from behaviours.skill_kit.stirring import MOVEMENTS, next_trial, stir_steps
from perception.learning.features import REST_TICKS, columns


@register
class ClassifySubstance(UsesModel, ProgramSkill):
    NAME = "classify_substance"
    MODEL_KIND = "stir"
    SUMMARY = "stir the dipped stick and classify the substance (StirLearn)"
    PARAMS = {
        "model": Param("str", "StirLearn model file (fvtree train stir)", "trees/models/stir_sim.npz"),
        "movement": Param("str", "stirring movement", "circle_large_slow", choices=tuple(MOVEMENTS)),
        "duration": Param("float", "how long to stir", 4.0, "s", min=0.5, max=60.0),
        "min_confidence": Param("float", "fail below this probability of the best class", 0.6, min=0.0, max=1.0),
        "min_drag": Param("float", "shear felt while stirring (rms change from rest, beyond the rest noise) "
                          "below this means the stick is not in anything (in the air 0-0.07 px, more only while a skin "
                          "still relaxes from the last stir; in the bowls 0.08-1.7 px, 5 % of trials under 0.15)",
                          0.1, "px", min=0.0),
    }
    READS = (keys.FV_LEFT, keys.FV_RIGHT, keys.STIR_TRIAL, keys.ROBOT_POSE, keys.ROBOT_FAULT, keys.ROBOT_MOVING)
    NEEDS = ("bowls",)
    WRITES = (keys.SUBSTANCE, keys.STIR_TRIAL)

    def program(self):
        from perception.learning.stir import classify  # scikit-learn: loaded by a run, not by `fvtree validate`

        if self.model is None:
            return self.fail(self.model_error)
        model = self.model
        trial = next_trial(self.read(keys.STIR_TRIAL))
        rows, fault = yield from stir_steps(self, self.p.movement, self.p.duration, trial)
        if fault:
            return self.fail(fault)
        drag = self._mean_drag(rows)
        if drag < self.p.min_drag:
            return self.fail(f"felt almost nothing while stirring (mean force {drag:.3f} px): "
                             "is the stick dipped in the substance?")
        label, probabilities = classify(model, np.asarray(rows))
        self.write(keys.SUBSTANCE, {"label": label, "probabilities": probabilities, "movement": self.p.movement})
        ranked = ", ".join(f"{k} {v:.2f}" for k, v in sorted(probabilities.items(), key=lambda kv: -kv[1]))
        if probabilities[label] < self.p.min_confidence:
            return self.fail(f"not sure which substance ({ranked}): stir again, or retrain with more trials")
        self.feedback_message = f"{label} ({ranked})"
        return Status.SUCCESS

    @staticmethod
    def _mean_drag(rows) -> float:
        """Shear along the pads felt while stirring (px, from the force columns): its rms change
        from the rest rows' mean, beyond their own noise (a skin's rest jitter spans 0.046-0.32 px,
        as much as the drag of a shallow dip)."""
        names = columns()
        shear = np.asarray(rows)[:, [names.index(f"{f}.{c}") for f in ("left", "right") for c in ("fx", "fz")]]
        rest, stirring = shear[:REST_TICKS], shear[REST_TICKS:]
        felt, noise = np.mean((stirring - rest.mean(axis=0)) ** 2), np.mean(rest.var(axis=0))
        return float(np.sqrt(max(felt - noise, 0.0)))
