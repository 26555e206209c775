// Stability analysis.
