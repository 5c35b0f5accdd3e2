"""visnav.navigation"""
