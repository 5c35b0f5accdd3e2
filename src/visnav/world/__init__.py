"""visnav.world"""
