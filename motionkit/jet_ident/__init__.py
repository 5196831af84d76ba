"""Jet thrust identification: bench logs, LSTM model, evaluation, export (issue 6)."""
