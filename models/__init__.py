"""pdmkit.models"""
