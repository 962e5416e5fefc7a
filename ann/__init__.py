"""Small neural networks mapping acceleration records to coupler force (numpy, scipy; scikit-learn, the optional
extra ``femref[train]``, only to train the scikit-learn-backed networks — see :mod:`ann.networks`)."""
