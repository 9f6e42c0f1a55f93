"""mechrel.scene"""
