"""Standard manoeuvres through FMUs, reference ships, IMO criteria, validation, reports."""
