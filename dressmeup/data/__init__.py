"""dressmeup.data"""
