"""visnav.sim"""
