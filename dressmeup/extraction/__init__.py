"""dressmeup.extraction"""
