"""Targets: how bytes reach a HAT. One small module per kind, chosen by URL (see :func:`open_target`)."""
