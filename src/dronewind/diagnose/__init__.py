"""Diagnosis: what the simulation gets wrong, the named cause, the extended model, the gain.

``fitting`` holds the statistics (response models, fits, held-out gain, significance,
ambiguity); ``features`` the per-flight residual features measured on processed data.
This package is the one place that uses both the simulator and the processing results.
"""
