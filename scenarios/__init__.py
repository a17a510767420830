"""Standard manoeuvres through FMUs, metrics, IMO criteria, reference ship, reports."""
