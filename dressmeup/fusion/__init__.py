"""dressmeup.fusion"""
