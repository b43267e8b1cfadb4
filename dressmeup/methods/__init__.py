"""dressmeup.methods"""
