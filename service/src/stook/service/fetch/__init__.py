"""The fetch layer: every job of a batch, or every batch of a report, as records."""
