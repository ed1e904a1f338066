"""Jinja2 templates and shipped C headers/sources (package data, no code)."""
