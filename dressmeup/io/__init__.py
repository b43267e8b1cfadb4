"""dressmeup.io"""
