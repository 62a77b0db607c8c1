"""The transport scores' table: CSV round trip and the Markdown columns."""

from ladders.study.population import TransportScore, read_scores_csv, scores_csv, scores_markdown


def _score(**changes):
    values = dict(
        name="lddmm/pole_ladder_residual/alpha2=1", method="pole_ladder_residual",
        label="pole ladder, with residuals", deformation="lddmm", alpha2=1.0, power=0.9,
        dice=0.8, n_detected=200, n_affected=244, strain_power=0.5, strain_dice=0.4,
        normal_power=0.95, normal_dice=0.91, auc=0.97, auc_low=0.9, auc_high=1.0,
        global_p=1e-4, fwer=0.05, fwer_low=0.02, fwer_high=0.09, wall_power=0.8,
        wall_dice=0.85,
    )  # fmt: skip
    values.update(changes)
    return TransportScore(**values)


def test_scores_csv_round_trip():
    scores = [_score(), _score(method="none", name="none", alpha2=None, fwer=None,
                               fwer_low=None, fwer_high=None, wall_power=None)]  # fmt: skip
    assert read_scores_csv(scores_csv(scores)) == scores


def test_markdown_gives_power_and_dice_of_every_test():
    table = scores_markdown([_score()])
    assert "normal-motion power / Dice" in table and "| 0.95 / 0.91 | 0.80 / 0.85 |" in table
    assert "0.050 [0.020, 0.090]" in table
