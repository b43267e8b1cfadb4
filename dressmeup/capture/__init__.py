"""dressmeup.capture"""
