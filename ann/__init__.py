"""Small neural networks mapping acceleration records to coupler force (numpy, scipy, scikit-learn)."""
