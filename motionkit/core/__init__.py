"""What every stage shares: its errors (`errors`), the checks of config values (`checks`),
TOML recipes (`tomlfile`), the optional extras (`extras`) and the zero-phase low-pass
(`filters`)."""
