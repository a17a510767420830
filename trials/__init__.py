"""What identification and validation share: trial logs, programmes, the runner, metrics.

The floor between ``fmu_model`` (the model) and its two users: ``identifier`` (logs in,
params out) and ``scenarios`` (manoeuvres, validation, reports). It imports only
``fmu_model``.
"""
