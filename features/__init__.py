"""pdmkit.features"""
