"""visnav.sensors"""
