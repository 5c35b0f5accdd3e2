"""visnav.vehicles"""
