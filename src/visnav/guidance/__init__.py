"""visnav.guidance"""
