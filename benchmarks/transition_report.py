"""Does MBIL-C's dynamics model T see the action? (benchmarks.harness.dynamics) One line per (settings, seed): one
expert step, T's error and what a perturbed action changes in T's prediction, in units of the states' std, and the
corrective labels T gives.

    python -m benchmarks.transition_report --env Walker2d-v4 --seeds 100 101 102 --settings \\
        '{"model_labels": "corrective"}' '{"model_labels": "corrective", "residual_transition": true}'
"""

import argparse
import json

from benchmarks.harness.cli import finite_float, run, seed


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--seeds", type=seed, nargs="+", default=[100])
    p.add_argument("--settings", nargs="+", default=['{"model_labels": "corrective"}'],
                   help="JSON settings of MBIL-C over the zoo's (alpha_model defaults to 1 so that T is fitted)")
    p.add_argument("--action-noise", type=finite_float, default=0.1, help="perturbation of a, in units of its std")
    a = p.parse_args(argv)
    from benchmarks.harness.dynamics import diagnostics_table, transition_diagnostics

    rows = []
    for text in a.settings:
        try:
            settings = json.loads(text)
        except json.JSONDecodeError as e:
            raise ValueError(f"--settings: expected a JSON object, found {text!r} ({e})") from None
        for s in a.seeds:
            rows.append(transition_diagnostics(a.env, s, settings, a.action_noise))
    print(diagnostics_table(rows))


if __name__ == "__main__":
    run(main)
