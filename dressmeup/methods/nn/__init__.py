"""dressmeup.methods.nn"""
