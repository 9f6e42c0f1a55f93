"""mechrel.io"""
