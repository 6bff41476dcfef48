"""CLI subcommands, one module each. Every module exposes ``register(subparsers)``,
which adds its parser and sets ``func(args) -> int`` as the handler."""
