"""visnav.mission"""
