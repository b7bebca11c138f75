"""pdmkit.experiments"""
