"""Our LWPR beside the reference library, protocol by protocol, over independent data draws."""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmarks.lib import lwpr_reference
from rigs.lwpr_draws import cross_case, final_nmse, irrelevant_case, mirror_case, mirror_samples_until_good
from rigs.tasks import CROSS_LWPR_PARAMS

# protocol: what it measures (every figure: lower is better)
PROTOCOLS = {
    "cross": "tutorial cross, tutorial settings: nMSE",
    "cross_untuned": "tutorial cross, each library's defaults: nMSE",
    "irrelevant20": "cross among 18 irrelevant inputs, 20,000 samples, defaults: nMSE",
    "mirror": "mirroring 18 -> 18, defaults: samples until held-out worst < 0.05 rad for good",
}


def ours(draws: int, slow_draws: int) -> dict[str, list]:
    """Our figures per draw: the two cross protocols over `draws`, the slower two over `slow_draws`."""
    figures: dict[str, list] = {name: [] for name in PROTOCOLS}
    for draw in tqdm(range(draws), desc="lwpr draws", leave=False, file=sys.stderr):
        case = cross_case(draw)
        figures["cross"].append(final_nmse(case, CROSS_LWPR_PARAMS))
        figures["cross_untuned"].append(final_nmse(case, {}))
        if draw < slow_draws:
            figures["irrelevant20"].append(final_nmse(irrelevant_case(draw), {}))
            figures["mirror"].append(mirror_samples_until_good(mirror_case(draw), {}))
    return figures


def reference(draws: int, source: Path | None) -> tuple[dict[str, list], str]:
    """The reference's figures on the same draws: measured when its source is given, else recorded."""
    if source is None:
        return {name: values[:draws] for name, values in lwpr_reference.RECORDED.items()}, "recorded"
    with tempfile.TemporaryDirectory() as work:
        binary = lwpr_reference.build(source, Path(work))
        return lwpr_reference.measure(binary, draws), "measured in this run"


def figure(value) -> float:
    """A draw's figure; a mirroring draw that never got there counts as infinitely many samples."""
    return np.inf if value is None else value


def summary(values: list) -> tuple[float, float]:
    """(median, worst)."""
    numbers = [figure(v) for v in values]
    return float(np.median(numbers)), float(np.max(numbers))


def table(mine: dict[str, list], theirs: dict[str, list], provenance: str) -> dict:
    """Prints the comparison; returns its figures."""
    figures = {}
    print(f"\nLWPR over independent data draws, beside the reference library ({provenance}):")
    print(f"  {'protocol':74} {'draws':>5} {'ours median / worst':>22} {'reference':>18} {'draws worse':>11}")
    for name, label in PROTOCOLS.items():
        values, ref = mine[name], theirs.get(name, [])[:len(mine[name])]
        median, worst = summary(values)
        ref_median, ref_worst = summary(ref) if len(ref) == len(values) else (np.nan, np.nan)
        worse = sum(1 for a, b in zip(values, ref) if figure(a) > figure(b))
        print(f"  {label:74} {len(values):>5} {median:>10.4g} / {worst:<9.4g} {ref_median:>7.4g} / {ref_worst:<8.4g}"
              f" {worse if ref else '-':>11}")
        figures.update({f"lwpr_{name}_median": median, f"lwpr_{name}_worst": worst, f"lwpr_{name}_draws": len(values),
                        f"reference_{name}_median": ref_median, f"reference_{name}_worst": ref_worst,
                        f"lwpr_{name}_draws_worse_than_reference": worse})
    return figures
