"""dressmeup.viz"""
