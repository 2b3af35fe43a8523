"""Reporting: tables, numbers and figures."""
