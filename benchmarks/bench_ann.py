"""Network training time and inference time per record, on a study's training sweep.

    python benchmarks/bench_ann.py STUDY_DIR [--study cases/studies/ann_study.yaml] [--repeats 3]

Reads ``STUDY_DIR/train.h5`` (written by ``femref study``), and for each network of the
study file, trained on the fem records as the study does: the training time (median of
``--repeats``), the inference time per record in one batch of every training record, and
the latency of a single record (the ``femref run`` path: one record stack through the
saved pipeline and network). Ratios to the MLP's training time are printed alongside.
Nothing is asserted: the tests check correctness, this measures speed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from bench_reduced import median_time  # benchmarks/ is the script's directory
from femref.study.run import feature_settings, read_set
from femref.study.spec import TRAIN, load_study
from femref.sweep import parse_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study_dir", type=Path)
    parser.add_argument("--study", type=Path, default=Path("cases/studies/ann_study.yaml"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    from ann.features import FeaturePipeline
    from ann.storage import Estimator
    from femref.study.run import base_case_data, set_sweep_data

    study, study_dir = load_study(args.study)
    sweep = parse_sweep(set_sweep_data(study, TRAIN, base_case_data(study, study_dir, str(args.study))), base_dir=study_dir)
    train = read_set(sweep, args.study_dir / "train.h5")
    probes = list(study.probes) if study.probes else list(train.data.probes)
    records, peaks = train.records("fem", probes), train.peaks("fem", study.coupler)
    masses = train.car_masses if study.car_masses else None
    rate = train.data.record_rate
    settings = feature_settings(study, train)

    print(f"{records.shape[0]} fem training records of {records.shape[1]} channels × {records.shape[2]} samples")
    print(f"{'network':8} {'train s':>9} {'batch µs/record':>16} {'single-record µs':>17} {'train / mlp':>12}")
    rows = {}
    for name, spec in study.networks.items():
        state = {}

        def train_once():
            pipeline = FeaturePipeline(settings).fit(records, rate, masses)
            state["estimator"] = Estimator(pipeline, spec.build().fit(pipeline.transform(records, rate, masses), peaks))

        training = median_time(train_once, args.repeats)
        estimator = state["estimator"]
        batch = median_time(lambda: estimator.predict(records, rate, masses), max(args.repeats, 5)) / records.shape[0]
        one, one_mass = records[:1], None if masses is None else masses[:1]
        single = median_time(lambda: estimator.predict(one, rate, one_mass), 50)
        rows[name] = (training, batch, single)
    reference = rows.get("mlp", next(iter(rows.values())))[0]
    for name, (training, batch, single) in rows.items():
        print(f"{name:8} {training:9.2f} {batch * 1e6:16.1f} {single * 1e6:17.0f} {training / reference:12.3f}")
    print(f"(fem run of one sample, from the sweep: {np.nanmedian(train.data.wall_time_s['fem']) * 1e3:.0f} ms)")


if __name__ == "__main__":
    main()
