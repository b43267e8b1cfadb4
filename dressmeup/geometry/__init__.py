"""dressmeup.geometry"""
