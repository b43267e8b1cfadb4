"""dressmeup.body"""
