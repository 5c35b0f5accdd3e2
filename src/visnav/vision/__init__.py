"""visnav.vision"""
