"""dressmeup.methods.uvparam"""
