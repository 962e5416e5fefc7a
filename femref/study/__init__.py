"""The network study (issue 5): train force networks on simulated impacts, score them against fem.

>>> from femref.study.spec import load_study
>>> from femref.study.run import run_study
>>> study, where = load_study("cases/studies/ann_study.yaml")               # doctest: +SKIP
>>> outcome = run_study(study.scaled(0.1), where, "quick_study", workers=2)  # doctest: +SKIP
>>> print(outcome.markdown())                                                # doctest: +SKIP

* :mod:`femref.study.spec` — the study file (base case, distribution, sets, networks);
* :mod:`femref.study.run` — sweeps, training per source, evaluation, ``study.h5``.

Command line: ``femref study STUDY.yaml [-o DIR] [--workers N | --scheduler ADDR] [--scale F]``.
"""
