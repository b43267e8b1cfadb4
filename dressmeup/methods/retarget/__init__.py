"""dressmeup.methods.retarget"""
