"""The network study (issue 5): train force networks on simulated impacts, score them against fem.

>>> from femref.study.spec import load_study
>>> from femref.study.run import run_study
>>> study, where = load_study("cases/studies/ann_study.yaml")               # doctest: +SKIP
>>> outcome = run_study(study.scaled(0.1), where, "quick_study", workers=2)  # doctest: +SKIP
>>> print(outcome.markdown())                                                # doctest: +SKIP

The study file: :mod:`femref.study.spec`; sweeps, training, evaluation: :mod:`femref.study.run`;
the inverse estimators' error bands: :mod:`femref.study.calibration`.
"""
