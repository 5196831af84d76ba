"""How work runs: process pools and Ray (`executors`, `workers`), progress lines (`progress`),
Ctrl-C and SIGTERM (`interrupts`), quieting third-party output (`silence`) and JAX on a CPU
(`jaxcpu`)."""
