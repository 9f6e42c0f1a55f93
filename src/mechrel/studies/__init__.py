"""mechrel.studies"""
