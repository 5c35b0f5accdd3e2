"""visnav.estimation"""
