"""dressmeup.bench"""
