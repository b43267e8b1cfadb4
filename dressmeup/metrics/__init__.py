"""dressmeup.metrics"""
