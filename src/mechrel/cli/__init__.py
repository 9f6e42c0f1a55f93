"""mechrel.cli"""
