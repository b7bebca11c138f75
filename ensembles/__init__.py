"""pdmkit.ensembles"""
