"""The MCAP motion dataset format: writer, reader, validation, AMP features (issue 3)."""
