"""The viser browser viewer (issue 8)."""
