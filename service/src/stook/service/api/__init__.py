"""The API layer: transport, retry policy, limits, clients, models, errors and redaction."""
