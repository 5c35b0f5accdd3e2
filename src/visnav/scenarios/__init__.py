"""visnav.scenarios"""
