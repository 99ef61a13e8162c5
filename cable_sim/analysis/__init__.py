"""Offline analysis tools built on the headless simulation core."""
